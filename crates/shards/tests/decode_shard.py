"""Decodes pl2map shards with the public MCAP tools only, from the schemas embedded
in the files (no code generated from this project's .proto).

Usage: python decode_shard.py SHARD.mcap [...]
Prints one JSON object: per-topic message counts, and for /labels the number of
frames, keypoints, valid points, segments and valid lines, the frame ids, and the
exact sums (as the bits of the IEEE double) of the valid 3D point and line coordinates, summed in message
order, so the Rust side can compare bit for bit.
"""
import json
import struct
import sys

from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory


def bits(x):
    return struct.unpack("<Q", struct.pack("<d", x))[0]


def main(paths):
    topics = {}
    frames = keypoints = valid_points = segments = valid_lines = 0
    frame_ids = []
    point_sum = 0.0
    line_sum = 0.0
    schemas = {}
    for path in paths:
        with open(path, "rb") as f:
            reader = make_reader(f, decoder_factories=[DecoderFactory()])
            for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True):
                topics[channel.topic] = topics.get(channel.topic, 0) + 1
                schemas[channel.topic] = schema.name
                if channel.topic != "/labels":
                    continue
                # The class was built at run time from the schema's FileDescriptorSet.
                assert type(decoded).DESCRIPTOR.full_name == "pl2map.FrameLabels"
                assert message.log_time == decoded.frame_id * 100_000_000
                n = len(decoded.point3d_ids)
                assert len(decoded.keypoints) == 2 * n and len(decoded.points3d) == 3 * n
                assert len(decoded.point_valid) == n
                m = len(decoded.track_ids)
                assert len(decoded.segments) == 4 * m and len(decoded.lines3d) == 6 * m
                assert len(decoded.line_valid) == m
                frames += 1
                frame_ids.append(decoded.frame_id)
                keypoints += n
                segments += m
                for i, ok in enumerate(decoded.point_valid):
                    if ok:
                        valid_points += 1
                        for v in decoded.points3d[3 * i:3 * i + 3]:
                            point_sum += v
                for i, ok in enumerate(decoded.line_valid):
                    if ok:
                        valid_lines += 1
                        for v in decoded.lines3d[6 * i:6 * i + 6]:
                            line_sum += v
    print(json.dumps({
        "topics": topics,
        "schemas": schemas,
        "frames": frames,
        "frame_ids": frame_ids,
        "keypoints": keypoints,
        "valid_points": valid_points,
        "segments": segments,
        "valid_lines": valid_lines,
        "point_sum_bits": bits(point_sum),
        "line_sum_bits": bits(line_sum),
    }, sort_keys=True))


if __name__ == "__main__":
    main(sys.argv[1:])
