"""ShardDataset under torch's DataLoader: for 0-3 workers, batch sizes 1 and 4 and 1 or 2
ranks, lock-stepped ranks together yield the epoch's global order, each rank the same
sequence whatever the worker count, and every frame exactly once (with 2 ranks and an
odd frame count, plus the documented padding: the order's first frame once more).

usage: workers_and_ranks.py SHARD_DIR
"""

import collections
import sys

import torch.utils.data as tud

import pl2map_shards as ps

SEED, EPOCH = 5, 2


def frame_ids(batch):
    return [f["frame_id"] for f in batch]


def rank_stream(folder, rank, world, workers, block, context=None):
    ds = ps.ShardDataset(folder, seed=SEED, rank=rank, world_size=world, batch_size=block)
    ds.set_epoch(EPOCH)
    loader = tud.DataLoader(
        ds,
        batch_size=block,
        num_workers=workers,
        collate_fn=frame_ids,
        multiprocessing_context=context,
    )
    out = [i for batch in loader for i in batch]
    assert len(out) == len(ds), (len(out), len(ds))
    return out


def main():
    folder = sys.argv[1]
    shards = ps.ShardSet(folder, "train")
    ids = [int(i) for i in shards.frame_ids]
    n = len(ids)
    loaders = 0
    for world in (1, 2):
        want = [ids[i] for i in ps.global_order(n, SEED, EPOCH, world=world)]
        by_workers = {}
        for workers in (0, 1, 2, 3):
            for block in (1, 4):
                streams = [rank_stream(folder, r, world, workers, block) for r in range(world)]
                loaders += world
                # Lock-stepped ranks: step k takes sample k of every rank.
                joined = [s[k] for k in range(len(streams[0])) for s in streams]
                assert joined == want, f"world {world}, {workers} workers, block {block}: {joined} != {want}"
                by_workers[(workers, block)] = streams
        first = next(iter(by_workers.values()))
        assert all(s == first for s in by_workers.values()), "the worker count changed a rank's stream"
        counts = collections.Counter(want)
        extra = collections.Counter(want[n:])  # the padding
        assert set(counts) == set(ids), "a frame is missing"
        assert all(counts[i] == 1 + extra[i] for i in ids), counts
        assert len(want) - n == (-n) % world, "padding beyond a multiple of the world size"
    # drop_last cuts instead of padding: each frame at most once.
    ds = ps.ShardDataset(folder, seed=SEED, rank=1, world_size=2, drop_last=True)
    assert len(list(ds)) == n // 2
    # Spawned workers get a pickled dataset, which reopens the folder itself.
    spawned = rank_stream(folder, 0, 1, 2, 1, context="spawn")
    assert spawned == [ids[i] for i in ps.global_order(n, SEED, EPOCH)]
    print(f"checked {loaders} loaders ({n} frames), drop_last and spawned workers")


if __name__ == "__main__":
    main()
