"""Reading and writing checkpoint files: atomic writes, safe loads, clear errors."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import torch

from dlo_env.core.atomic import atomic_path
from dlo_env.errors import InputError, MissingFileError

#: Marks a file as a dlo shape-model checkpoint.
FORMAT = "dlo-shape-model"
#: Bumped whenever the checkpoint layout changes incompatibly.
FORMAT_VERSION = 1


def save_atomic(obj: dict[str, Any], path: str | os.PathLike) -> Path:
    """``torch.save`` to a temporary file in the same folder, then ``os.replace`` it into place.

    A reader never sees a half-written file, and an interrupted write leaves the old one.
    """
    path = Path(path)
    with atomic_path(path) as tmp:
        torch.save(obj, tmp)
    return path


def load_checkpoint(path: str | os.PathLike, name: str = "path", *, kind: str = FORMAT,
                    version: int = FORMAT_VERSION) -> dict[str, Any]:
    """Load a checkpoint written by ``save_atomic`` with ``weights_only=True`` and check its format.

    Args:
        path: The file.
        name: What to call it in messages (the argument or flag it came from).
        kind: The ``format`` the file must carry (a shape model by default).
        version: The ``format_version`` this code reads.

    Raises:
        FileNotFoundError: If ``path`` does not exist.
        ValueError: Naming ``name`` if the file is not a readable checkpoint, is not of
            ``kind``, or has another format version.
    """
    path = Path(path)
    if not path.is_file():
        raise MissingFileError(f"{name}: no checkpoint file at {str(path)!r}")
    try:
        data = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises many types for corrupt or foreign files
        text = str(exc).splitlines()[0] if str(exc) else ""
        if "weights_only" in str(exc):  # torch's advice to unpickle the file: never taken here
            text = "not a file of tensors and plain data (torch.load with weights_only=True)"
        raise InputError(
            f"{name}: {str(path)!r} is not a readable torch checkpoint "
            f"({type(exc).__name__}: {text})"
        ) from exc
    if not isinstance(data, dict) or data.get("format") != kind:
        raise InputError(f"{name}: {str(path)!r} is not a {kind} checkpoint")
    found = data.get("format_version")
    if found != version:
        raise InputError(
            f"{name}: {str(path)!r} has checkpoint format version {found!r}; "
            f"this version of latent_model reads version {version}"
        )
    return data
