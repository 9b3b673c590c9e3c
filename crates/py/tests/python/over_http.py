"""A shard set served by a real HTTP server (Python's http.server on 127.0.0.1) reads
as the local folder does: ShardSet and ShardDataset take the URL, fetch the set into the
shard cache (PL2MAP_SHARD_CACHE) with its hashes checked, and yield the same frames.

usage: over_http.py SHARD_DIR CACHE_DIR
"""

import functools
import hashlib
import http.server
import os
import sys
import threading

import numpy as np

import pl2map_shards as ps


def same(a, b):
    assert a["frame_id"] == b["frame_id"]
    assert hashlib.sha256(a["image"]).digest() == hashlib.sha256(b["image"]).digest()
    for key in ("keypoints", "points3d", "segments", "lines3d"):
        assert a[key].tobytes() == b[key].tobytes(), key
    for key in ("point_valid", "line_valid", "point3d_ids", "track_ids"):
        assert np.array_equal(a[key], b[key]), key


def main():
    folder, cache = sys.argv[1], sys.argv[2]
    os.environ["PL2MAP_SHARD_CACHE"] = cache
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=folder)
    handler.log_message = lambda *args: None
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        url = f"http://127.0.0.1:{server.server_address[1]}/shards"
        os.symlink(".", os.path.join(folder, "shards"))  # the set under a path
        local = ps.ShardSet(folder, "train")
        remote = ps.ShardSet(url, "train")
        assert os.path.realpath(remote.folder).startswith(os.path.realpath(cache)), remote.folder
        assert list(remote.frame_ids) == list(local.frame_ids)
        for i in range(len(local)):
            same(remote.read(i), local.read(i))
        ds_local = ps.ShardDataset(folder, seed=9, rank=0, world_size=1)
        ds_remote = ps.ShardDataset(url, seed=9, rank=0, world_size=1)
        for a, b in zip(ds_local, ds_remote, strict=True):
            same(a, b)
        try:
            ps.ShardSet(f"http://127.0.0.1:{server.server_address[1]}/nothing-here")
        except ps.ShardError as e:
            assert "nothing-here" in str(e), e
            print(f"missing set: {e}")
        else:
            raise AssertionError("a URL without a set opened")
    finally:
        server.shutdown()
    print(f"over http: {len(local)} frames from {url}")


if __name__ == "__main__":
    main()
