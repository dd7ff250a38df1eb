"""The one ``.npz`` layout of the project's datasets: typed arrays plus a JSON ``metadata``.

A dataset file is a plain ``.npz`` (no pickles) whose ``metadata`` string names its format and
format version, so a loader recognises a foreign or outdated file and says so in one line.
Each format declares its arrays as a table ``name -> (dtype, dims)``, where a dim is a fixed
size or a symbol (``"N"``, ``"T"``, ``"n"``) that must agree across the arrays.
"""

from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from dlo_env.core.atomic import atomic_path
from dlo_env.errors import InputError, MissingFileError

#: array name -> (dtype, dims); a dim is an int (fixed) or a symbol shared across arrays.
ArraySpec = dict[str, tuple[np.dtype, tuple[object, ...]]]


def _dims(dims: tuple[object, ...]) -> str:
    return "(" + ", ".join(str(d) for d in dims) + ")"


def check_arrays(spec: ArraySpec, arrays: dict[str, Any]) -> dict[str, int]:
    """Check dtypes and shapes of ``arrays`` against ``spec``; returns the symbol sizes.

    Raises:
        ValueError: Naming the first array of the wrong dtype, rank or size.
    """
    sizes: dict[str, int] = {}
    for name, (dtype, dims) in spec.items():
        arr = arrays[name]
        if not isinstance(arr, np.ndarray) or arr.dtype != dtype or arr.ndim != len(dims):
            got = f"{arr.dtype} {arr.shape}" if isinstance(arr, np.ndarray) else type(arr).__name__
            raise InputError(f"{name} must be a {dtype} array of shape {_dims(dims)}, got {got}")
        for dim, size in zip(dims, arr.shape):
            ok = size == dim if isinstance(dim, int) else sizes.setdefault(str(dim), size) == size
            if not ok:
                known = ", ".join(f"{k}={v}" for k, v in sizes.items()) or "none yet"
                raise InputError(f"{name} must have shape {_dims(dims)} consistent with the "
                                 f"other arrays ({known}), got {arr.shape}")
    return sizes


def save_npz(path: str | os.PathLike[str], arrays: dict[str, np.ndarray],
             metadata: dict[str, Any], format_name: str, format_version: int) -> Path:
    """Write ``arrays`` and ``metadata`` to ``path`` atomically, byte-reproducibly.

    The zip entries carry a fixed timestamp, so equal datasets give byte-identical files.
    """
    path = Path(path)
    meta = {**metadata, "format": format_name, "format_version": format_version}
    entries = {**arrays, "metadata": np.array(json.dumps(meta, sort_keys=True))}
    with atomic_path(path) as tmp:
        with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_STORED, allowZip64=True) as zf:
            for name, arr in entries.items():
                info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
                with zf.open(info, "w", force_zip64=True) as f:
                    np.lib.format.write_array(f, np.asarray(arr), allow_pickle=False)
    return path


def open_npz(path: str | os.PathLike[str], where: str,
             what: str = "file") -> np.lib.npyio.NpzFile:
    """``np.load(path, allow_pickle=False)`` of an ``.npz`` archive (use it as a context).

    Raises:
        ValueError: One line starting with ``where`` (e.g. the path, or the flag that gave it)
            and naming ``what`` the file should be: not an archive numpy wrote, unreadable, or
            a single ``.npy`` array.
    """
    try:
        loaded = np.load(path, allow_pickle=False)
    except ValueError as exc:  # neither a zip nor an .npy: numpy would have to unpickle it
        raise InputError(f"{where} is not a readable .npz {what} (corrupt, or not written by "
                         "numpy)") from exc
    except (OSError, EOFError, zipfile.BadZipFile) as exc:
        raise InputError(f"{where} is not a readable .npz {what} ({exc})") from exc
    if not isinstance(loaded, np.lib.npyio.NpzFile):
        raise InputError(f"{where} is not a {what}: it holds one array, not an .npz archive")
    return loaded


def load_npz(path: str | os.PathLike[str], *, format_name: str,
             format_version: int | tuple[int, ...],
             names: tuple[str, ...], what: str, missing_hint: str,
             optional: tuple[str, ...] = ()
             ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Read the arrays ``names`` and the metadata of a ``format_name`` file.

    Args:
        path: The ``.npz`` file.
        format_name: The ``format`` its metadata must name.
        format_version: The version (or versions) this code reads.
        names: Arrays that must be present.
        optional: Arrays read when present (an earlier version's files lack them).
        what: What the file is, for messages ("shape dataset").
        missing_hint: What to do when there is no file (a command that makes one).

    Raises:
        FileNotFoundError: No file at ``path`` (the message says how to make one).
        ValueError: One line naming the file and what is wrong with it: not an ``.npz``,
            no metadata, another format or version, a missing array.
    """
    path = Path(path)
    if not path.is_file():
        raise MissingFileError(f"no {what} at {str(path)!r}; {missing_hint}")
    where = repr(str(path))
    loaded = open_npz(path, where, what)
    try:
        with loaded as npz:
            present = set(npz.files)
            if "metadata" not in present:
                raise InputError(f"{where} is not a {what}: no 'metadata' array")
            meta = json.loads(str(npz["metadata"][()]))
            if not isinstance(meta, dict) or meta.get("format") != format_name:
                raise InputError(f"{where} is not a {what}: metadata 'format' is not "
                                 f"{format_name!r}")
            version = meta.get("format_version")
            readable = (format_version,) if isinstance(format_version, int) else format_version
            if version not in readable:
                shown = " or ".join(map(str, readable))
                raise InputError(f"{where} has format_version {version!r}; this version of dlo "
                                 f"reads format_version {shown} (collect it again)")
            missing = [name for name in names if name not in present]
            if missing:
                raise InputError(f"{where} lacks the array(s) {', '.join(missing)}")
            arrays = {name: npz[name] for name in (*names, *optional) if name in present}
    except (OSError, zipfile.BadZipFile, json.JSONDecodeError, EOFError) as exc:
        raise InputError(f"{where} is not a readable .npz {what}: {exc}") from exc
    except ValueError as exc:
        if str(path) in str(exc):
            raise
        raise InputError(f"{where} is not a readable .npz {what}: {exc}") from exc
    return arrays, meta
