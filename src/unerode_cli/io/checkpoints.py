"""Checkpoints of long runs: named arrays in one ``.npz`` file, written atomically (stored, or
zip-deflated with ``compressed``; both read alike)."""

from __future__ import annotations

import json
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


def write_checkpoint(path: Path, *, compressed: bool = False, **arrays: object) -> None:
    """Save ``arrays`` (NumPy arrays, numbers or strings) to ``path`` atomically, so a crash
    leaves the previous checkpoint whole; ``compressed``: zip-deflated (``np.savez_compressed``:
    smaller and slower to write, for large particle states)."""
    with atomic_path(path) as tmp, open(tmp, "wb") as handle:
        (np.savez_compressed if compressed else np.savez)(handle, **arrays)


def read_checkpoint(path: Path) -> dict[str, np.ndarray]:
    """Every array of a checkpoint written by :func:`write_checkpoint` (no pickles)."""
    with np.load(path, allow_pickle=False) as saved:
        return {name: saved[name] for name in saved.files}


#: Key of a state checkpoint's JSON part (numbers, text, lists and mappings of them).
_JSON_KEY = "state.json"


def write_state_checkpoint(path: Path, fingerprint: str, step: int, state: dict[str, object],
                           compressed: bool = False) -> None:
    """Save a run after ``step`` steps: its ``fingerprint``, and ``state`` — NumPy arrays as
    arrays, every other value (numbers, text, lists and mappings of them) as one JSON text,
    whose floats keep every bit (``repr``); ``compressed`` as in :func:`write_checkpoint`."""
    arrays = {f"array.{name}": value for name, value in state.items() if isinstance(value, np.ndarray)}
    rest = {name: value for name, value in state.items() if not isinstance(value, np.ndarray)}
    write_checkpoint(path, compressed=compressed, fingerprint=fingerprint, step=step,
                     **{_JSON_KEY: json.dumps(rest)}, **arrays)


def read_state_checkpoint(path: Path) -> tuple[str, int, dict[str, object]]:
    """(fingerprint, step, state) of a checkpoint written by :func:`write_state_checkpoint`;
    InputError when the file is not one."""
    try:
        saved = read_checkpoint(path)
        state: dict[str, object] = json.loads(str(saved[_JSON_KEY]))
        fingerprint, step = str(saved["fingerprint"]), int(saved["step"])
    except (OSError, KeyError, ValueError) as exc:
        raise InputError(f"the checkpoint {path} cannot be read ({exc}); run without --resume.") from None
    for key, value in saved.items():
        if key.startswith("array."):
            state[key[len("array."):]] = np.array(value)
    return fingerprint, step, state


def read_checkpoint_header(path: Path) -> tuple[str, int]:
    """(fingerprint, step) of a state checkpoint, without its arrays; InputError when unreadable."""
    import zipfile

    try:
        with np.load(path, allow_pickle=False) as saved:
            return str(saved["fingerprint"]), int(saved["step"])
    except (OSError, EOFError, KeyError, ValueError, zipfile.BadZipFile) as exc:
        raise InputError(f"the state {path} cannot be read ({exc}); start afresh with --overwrite.") from None
