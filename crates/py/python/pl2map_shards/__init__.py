"""Read pl2map training shards from Python.

The reading and decoding are the Rust shard reader's (crates/shards), compiled into the
extension module ``pl2map_shards._native``; this package adds a PyTorch-compatible
dataset (``ShardDataset``) on top. The API is documented in docs/formats.md section 6.
"""

from ._native import (
    ShardError,
    ShardSet,
    __version__,
    epoch_indices,
    epoch_length,
    global_order,
    permutation,
)
from ._dataset import ShardDataset

__all__ = [
    "ShardDataset",
    "ShardError",
    "ShardSet",
    "__version__",
    "epoch_indices",
    "epoch_length",
    "global_order",
    "permutation",
]
