"""A chunk made away from the driver, as a task on any node (``RayBackend``'s workers).

A task makes its chunk in a temporary folder of its own node and returns the file's bytes;
the driver writes them atomically into ``OUT.parts/``
(:func:`dlo_env.dataset.chunks.run_chunks`), so nodes need no shared file system. Results are
identical to the local process pool for the same seed, by construction: chunk ``i`` depends
only on the seed and ``i``. A chunk is written once, when its task returns, so a task run
again after its worker died loses nothing and makes nothing twice; an interrupted run resumes
from the written chunks as with the local pool.
"""

from __future__ import annotations

import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

try:
    import fcntl
except ImportError:  # Windows: killed workers' folders stay
    fcntl = None  # type: ignore[assignment]


#: Prefix of the folder a task makes its chunk in.
CHUNK_FOLDER_PREFIX = "dlo-chunk-"
#: The file in a chunk folder that its task holds locked (``fcntl.flock``) while it works.
LOCK_FILE = ".lock"
#: A chunk folder without a lock file is left alone this long (seconds): it may be being made.
UNLOCKED_GRACE = 3600.0


def make_chunk_bytes(job: Any, index: int, size: int) -> bytes:
    """Make chunk ``index`` of ``job`` in a temporary folder; the bytes of its file.

    A worker that is killed cannot remove its folder, so each task first removes the folders
    whose lock no task holds (``remove_orphan_chunk_folders``); a lock is released by the
    system when its process ends, in any container sharing the folder.
    """
    root = Path(tempfile.gettempdir())
    remove_orphan_chunk_folders(root)
    folder = Path(tempfile.mkdtemp(prefix=CHUNK_FOLDER_PREFIX, dir=root))
    with open(folder / LOCK_FILE, "w") as lock:
        if fcntl is not None:
            fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            path = folder / f"chunk-{index:06d}.npz"
            job.write(index, size, path, None)
            return path.read_bytes()
        finally:
            shutil.rmtree(folder, ignore_errors=True)


def remove_orphan_chunk_folders(root: Path) -> list[Path]:
    """Remove the chunk folders under ``root`` whose lock no process holds; those removed.

    A folder without a lock file is removed only when older than ``UNLOCKED_GRACE``. Nothing
    is removed where ``fcntl`` is missing (Windows).
    """
    if fcntl is None:
        return []
    removed = []
    for folder in root.glob(f"{CHUNK_FOLDER_PREFIX}*"):
        try:
            lock_path = folder / LOCK_FILE
            if not lock_path.is_file():
                if time.time() - folder.stat().st_mtime < UNLOCKED_GRACE:
                    continue
            else:
                with open(lock_path) as lock:
                    fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)  # held: a live task
        except OSError:  # BlockingIOError (held), gone meanwhile, or not ours to read
            continue
        shutil.rmtree(folder, ignore_errors=True)
        if not folder.exists():
            removed.append(folder)
    return removed
