"""Checkpoints of long runs: named arrays in one ``.npz`` file, written atomically."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from unerode_cli.errors import InputError
from unerode_cli.io.paths import atomic_path, check_output


def checkpoint_path(output: Path) -> Path:
    """Where the run writing ``output`` keeps its checkpoint: ``.OUT.checkpoint.npz`` beside it."""
    return output.with_name(f".{output.name}.checkpoint.npz")


def check_checkpoint(output: Path, resume: bool, overwrite: bool, inputs: tuple[Path, ...]) -> None:
    """Refuse (InputError, via ``check_output``) a checkpoint left by an unfinished run of
    ``output`` unless it is continued (--resume) or replaced (--overwrite): never silently."""
    path = checkpoint_path(output)
    if path.exists() and not (resume or overwrite):
        raise InputError(f"an unfinished run left its checkpoint {path}; pass --resume to continue it "
                         "or --overwrite to start afresh.")
    check_output(path, True, inputs)


def write_checkpoint(path: Path, **arrays: object) -> None:
    """Save ``arrays`` (NumPy arrays, numbers or strings) to ``path`` atomically, so a crash
    leaves the previous checkpoint whole."""
    with atomic_path(path) as tmp, open(tmp, "wb") as handle:
        np.savez(handle, **arrays)


def read_checkpoint(path: Path) -> dict[str, np.ndarray]:
    """Every array of a checkpoint written by :func:`write_checkpoint` (no pickles)."""
    with np.load(path, allow_pickle=False) as saved:
        return {name: saved[name] for name in saved.files}
