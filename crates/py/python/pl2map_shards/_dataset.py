"""``ShardDataset``: one split of a shard folder as an iterable of frame dicts, a
``torch.utils.data.IterableDataset`` when PyTorch is installed (a plain iterable
otherwise; torch is never required).

The order (docs/formats.md section 6, "Order") is computed in Rust
(``pl2map_shards.epoch_indices``): a seeded permutation of the split per epoch, padded to
a multiple of the world size as torch's ``DistributedSampler`` pads (or cut, with
``drop_last``); rank ``r`` of ``R`` takes global positions ``r, r + R, ...``; DataLoader
worker ``w`` of ``W`` takes blocks ``w, w + W, ...`` of ``batch_size`` samples of its
rank's stream, which the DataLoader hands back in turn, so a rank sees the same
sequence whatever the number of workers.
"""

import os

from ._native import ShardSet, epoch_indices, epoch_length

try:  # PyTorch is optional.
    from torch.utils.data import IterableDataset as _Base
    from torch.utils.data import get_worker_info as _worker_info
except ImportError:  # pragma: no cover - exercised where torch is absent
    _Base = object

    def _worker_info():
        return None


def _distributed():
    """(rank, world size) of torch.distributed when it is initialised, else (0, 1)."""
    try:
        import torch.distributed as dist
    except ImportError:
        return 0, 1
    if dist.is_available() and dist.is_initialized():
        return dist.get_rank(), dist.get_world_size()
    return 0, 1


class ShardDataset(_Base):
    """Frames of one split of a shard folder, in a seeded order shared by every rank
    and DataLoader worker.

    source: a shard folder (``<work>/shard``) or an s3:// / https:// URL.
    split: "train" or "test".
    seed, shuffle: the order; without shuffle the reading order (shards in manifest
        order, frames by id).
    rank, world_size: this process's place in a distributed job (default: from
        torch.distributed when initialised, else 0 of 1).
    batch_size: the DataLoader's batch size (1 with ``batch_size=None``); workers take
        blocks of this many samples so that the DataLoader's batches come out in the
        rank's order.
    drop_last: cut the epoch to a multiple of world_size instead of padding it.
    decode_image: add ``pixels`` (a uint8 array) to each frame.
    verify: hash the split's shards against the manifest when opening.
    transform: a function applied to each frame dict (in the worker).
    """

    def __init__(
        self,
        source,
        split="train",
        *,
        seed=0,
        shuffle=True,
        rank=None,
        world_size=None,
        batch_size=1,
        drop_last=False,
        decode_image=False,
        verify=True,
        transform=None,
        cache_bytes=64 << 20,
    ):
        if (rank is None) != (world_size is None):
            raise ValueError("give both rank and world_size, or neither")
        if rank is None:
            rank, world_size = _distributed()
        self.split = split
        self.seed = int(seed)
        self.shuffle = bool(shuffle)
        self.rank = int(rank)
        self.world_size = int(world_size)
        self.batch_size = int(batch_size or 1)
        self.drop_last = bool(drop_last)
        self.decode_image = bool(decode_image)
        self.transform = transform
        self.cache_bytes = int(cache_bytes)
        # Opened (and verified, fetched when a URL) here, in the main process; the
        # workers reopen the local folder (see _shards).
        self._set = ShardSet(str(source), split, verify=verify, cache_bytes=self.cache_bytes)
        self._pid = os.getpid()
        self.folder = self._set.folder
        self.frames = len(self._set)
        self.epoch = 0
        self._start = 0  # global positions consumed before this process's iteration
        self._seen = 0  # samples this process yielded since its iteration began
        # Fails now (not in a worker) on a bad rank or world size.
        self._indices(0, 1)

    # -- order ---------------------------------------------------------------------

    def _indices(self, worker, workers):
        return epoch_indices(
            self.frames,
            self.seed,
            self.epoch,
            world=self.world_size,
            rank=self.rank,
            workers=workers,
            worker=worker,
            block=self.batch_size,
            start=self._start,
            drop_last=self.drop_last,
            shuffle=self.shuffle,
        )

    def set_epoch(self, epoch):
        """Selects the epoch's order (as DistributedSampler.set_epoch). A resume
        position (load_state_dict) is kept while the epoch stays the same."""
        epoch = int(epoch)
        if epoch != self.epoch:
            self.epoch = epoch
            self._start = 0
        self._seen = 0

    def __len__(self):
        """Samples this rank yields in a whole epoch."""
        total = epoch_length(self.frames, world=self.world_size, drop_last=self.drop_last)
        return total // self.world_size

    # -- reading -------------------------------------------------------------------

    def _shards(self):
        # A DataLoader worker is a forked (or spawned) copy: it opens the folder itself,
        # without hashing again (the main process verified the same files).
        if self._set is None or self._pid != os.getpid():
            self._set = ShardSet(
                str(self.folder), self.split, verify=False, cache_bytes=self.cache_bytes
            )
            self._pid = os.getpid()
        return self._set

    def __iter__(self):
        info = _worker_info()
        worker, workers = (0, 1) if info is None else (info.id, info.num_workers)
        shards = self._shards()
        indices = self._indices(worker, workers)
        self._seen = 0
        for i in indices:
            frame = shards.read(int(i), decode_image=self.decode_image)
            self._seen += 1
            yield frame if self.transform is None else self.transform(frame)

    def __getstate__(self):
        state = self.__dict__.copy()
        state["_set"] = None  # the Rust reader is not picklable; reopened in _shards
        return state

    # -- resuming ------------------------------------------------------------------

    def state_dict(self, samples_seen=None):
        """The position to resume from: the epoch and the global positions consumed.

        samples_seen: samples this rank has taken from its loader in this epoch (since
        the last load_state_dict). Omitted, the dataset's own count is used, which is
        right only when it is iterated in this process (num_workers=0); with DataLoader
        workers pass the count (e.g. steps x batch size).
        """
        seen = self._seen if samples_seen is None else int(samples_seen)
        return {
            "epoch": self.epoch,
            "consumed": self._start + seen * self.world_size,
            "seed": self.seed,
            "shuffle": self.shuffle,
            "frames": self.frames,
            "world_size": self.world_size,
            "drop_last": self.drop_last,
        }

    def load_state_dict(self, state):
        """Continues the epoch of `state` after the positions it consumed: the next
        iteration yields the rest of that epoch's order (the same remaining samples as
        the interrupted run when the world size is the same)."""
        for key in ("seed", "shuffle", "frames", "drop_last"):
            if state[key] != getattr(self, key):
                raise ValueError(
                    f"state_dict was saved with {key}={state[key]!r}, this dataset has "
                    f"{key}={getattr(self, key)!r}"
                )
        total = epoch_length(self.frames, world=self.world_size, drop_last=self.drop_last)
        consumed = int(state["consumed"])
        if not 0 <= consumed <= total:
            raise ValueError(f"consumed={consumed} is outside the epoch's {total} samples")
        self.epoch = int(state["epoch"])
        self._start = consumed
        self._seen = 0

    def __repr__(self):
        return (
            f"ShardDataset({self.folder!r}, split={self.split!r}, frames={self.frames}, "
            f"seed={self.seed}, epoch={self.epoch}, rank={self.rank}/{self.world_size})"
        )
