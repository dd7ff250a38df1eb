"""Atomic file writes: the project's one mechanism for "nothing the user wrote is lost".

Every file the project writes (datasets, tasks, checkpoints, models, CSV/JSON results,
figures) goes through ``atomic_path``: the writer fills a temporary file in the same folder,
which then replaces the target in one ``os.replace``. A reader never sees a half-written file,
and an interrupted write leaves the previous file as it was.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """A temporary path to write instead of ``path``; it replaces ``path`` on success.

    The temporary name keeps ``path``'s suffix, so writers that infer the format from it
    (``np.savez``, ``savefig``, SB3's ``save``) behave as for ``path``. On an exception the
    temporary file is removed and ``path`` is untouched. Missing parent folders are created.

    Example:
        >>> with atomic_path("results.json") as tmp:
        ...     tmp.write_text(text)
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.",
                                suffix=f".tmp{path.suffix}")
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        os.chmod(tmp, 0o644)  # mkstemp makes 0600; results are meant to be shared
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_text_atomic(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` to ``path`` atomically (see ``atomic_path``); returns the path."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, newline="")
    return Path(path)


def file_digest(path: str | os.PathLike) -> str:
    """The first 16 hex digits of the SHA-256 of a file ("" if there is none)."""
    p = Path(path)
    if not p.is_file():
        return ""
    return hashlib.sha256(p.read_bytes()).hexdigest()[:16]
