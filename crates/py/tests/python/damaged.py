"""A damaged shard reaches Python as pl2map_shards.ShardError naming the shard (and,
when a frame is being read, the frame).

usage: damaged.py RECORDED_DIR BARE_DIR DAMAGED_SHARD
  RECORDED_DIR: a shard folder with its stage.json, one shard changed afterwards;
  BARE_DIR: the same without stage.json (the manifest's hashes alone);
  DAMAGED_SHARD: the changed shard's file in RECORDED_DIR.
"""

import os
import sys

import pl2map_shards as ps


def expect_error(what, fn):
    try:
        fn()
    except ps.ShardError as e:
        print(f"{what}: {e}")
        return e
    raise AssertionError(f"{what}: no ShardError")


def main():
    recorded, bare, damaged = sys.argv[1:4]
    name = os.path.basename(damaged)

    # Opening checks the hashes: as the trainer does (stage.json), and from the manifest.
    e = expect_error("recorded folder", lambda: ps.ShardSet(recorded, "train"))
    assert name in str(e) and "changed after the shard stage recorded it" in str(e), e
    e = expect_error("bare folder", lambda: ps.ShardSet(bare, "train"))
    assert name in str(e) and "sha256" in str(e), e
    assert e.shard is not None and os.path.basename(e.shard) == name, e.shard
    e = expect_error("dataset", lambda: ps.ShardDataset(bare))
    assert name in str(e)

    # Unchecked, the damage shows when its chunk is read: the error names the shard and
    # the frame, and the frames of the other shards still read.
    shards = ps.ShardSet(bare, "train", verify=False)
    failed, read = [], 0
    for i in range(len(shards)):
        try:
            shards.read(i)
            read += 1
        except ps.ShardError as err:
            failed.append(err)
    assert failed, "no frame of the damaged shard failed to read"
    for err in failed:
        assert os.path.basename(err.shard) == name, err.shard
        assert err.frame_id is not None and f"frame {err.frame_id}" in str(err), err
        assert name in str(err), err
    print(f"first read error: {failed[0]}")
    assert read >= len(shards) - 4, (read, len(shards))

    # Not a shard folder at all.
    e = expect_error("missing folder", lambda: ps.ShardSet(os.path.join(bare, "nope")))
    assert "manifest.json" in str(e), e
    expect_error("unknown split", lambda: ps.ShardSet(bare, "val", verify=False))
    print(f"damaged checked: {len(failed)} frame(s) of {name} raised, {read} read")


if __name__ == "__main__":
    main()
