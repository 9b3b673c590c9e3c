"""Resuming mid-epoch: a dataset loaded with another's state_dict yields the rest of
the interrupted epoch's order (in the main process and with DataLoader workers on two
ranks, with another worker count after the resume), then whole epochs again.

usage: resume.py SHARD_DIR
"""

import itertools
import sys

import torch.utils.data as tud

import pl2map_shards as ps

SEED = 3


def ids_of(frames):
    return [f["frame_id"] for f in frames]


def frame_ids(batch):
    return ids_of(batch)


def main():
    folder = sys.argv[1]
    n = len(ps.ShardSet(folder))
    all_ids = [int(i) for i in ps.ShardSet(folder).frame_ids]

    # In the main process: the dataset counts what it yielded.
    ds = ps.ShardDataset(folder, seed=SEED, rank=0, world_size=1)
    ds.set_epoch(1)
    full = ids_of(ds)
    assert sorted(full) == sorted(all_ids)
    ds.set_epoch(1)
    head = ids_of(itertools.islice(iter(ds), 5))
    state = ds.state_dict()
    assert state["epoch"] == 1 and state["consumed"] == 5, state
    resumed = ps.ShardDataset(folder, seed=SEED, rank=0, world_size=1)
    resumed.load_state_dict(state)
    resumed.set_epoch(1)  # the same epoch keeps the resume position
    rest = ids_of(resumed)
    assert head + rest == full, (head, rest, full)
    resumed.set_epoch(2)
    nxt = ids_of(resumed)
    assert sorted(nxt) == sorted(all_ids) and nxt != full

    # Two ranks with two workers, batches of 2: each rank takes 2 batches, then stops.
    world, batch, steps = 2, 2, 2
    global_ids = [all_ids[i] for i in ps.global_order(n, SEED, 4, world=world)]
    states = []
    taken = []
    for rank in range(world):
        d = ps.ShardDataset(folder, seed=SEED, rank=rank, world_size=world, batch_size=batch)
        d.set_epoch(4)
        loader = tud.DataLoader(d, batch_size=batch, num_workers=2, collate_fn=frame_ids)
        got = [i for b in itertools.islice(iter(loader), steps) for i in b]
        taken.append(got)
        states.append(d.state_dict(samples_seen=steps * batch))
    assert states[0] == states[1], states
    assert states[0]["consumed"] == world * steps * batch, states[0]
    # The resumed job runs with three workers and batches of 3.
    rest = []
    for rank in range(world):
        d = ps.ShardDataset(folder, seed=SEED, rank=rank, world_size=world, batch_size=3)
        d.load_state_dict(states[0])
        loader = tud.DataLoader(d, batch_size=3, num_workers=3, collate_fn=frame_ids)
        rest.append([i for b in loader for i in b])
    before = [taken[r][k] for k in range(len(taken[0])) for r in range(world)]
    after = [rest[r][k] for k in range(len(rest[0])) for r in range(world)]
    assert before + after == global_ids, (before, after, global_ids)

    # A state of another order is refused.
    other = ps.ShardDataset(folder, seed=SEED + 1, rank=0, world_size=1)
    try:
        other.load_state_dict(state)
    except ValueError as e:
        assert "seed" in str(e), e
    else:
        raise AssertionError("a state_dict of another seed was accepted")
    print(f"resume checked: {len(head)} + {len(rest[0]) + len(rest[1])} frames")


if __name__ == "__main__":
    main()
