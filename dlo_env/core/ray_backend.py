"""Ray as the engine of chunked collection and of evaluations, when one machine is not enough.

:class:`RayBackend` runs the chunks of a :class:`dlo_env.dataset.chunks.ChunkJob` as Ray tasks,
on a local Ray runtime or on the cluster at ``address``. A task makes its chunk in a temporary
folder of its own node and returns the file's bytes; the driver writes them atomically into
``OUT.parts/``, so nodes need no shared file system. Results are identical to the local process
pool for the same seed, by construction: chunk ``i`` depends only on the seed and ``i``. A task
whose worker dies (killed, node lost) is run again by Ray (``max_retries``); a chunk is written
once, when its task returns, so nothing is lost and nothing is made twice. An interrupted run
resumes from the written chunks as with the local pool.

``RayBackend.map`` is the general form: any function over a list of argument tuples, one task
each; the benchmark and ``dlo evaluate`` run their cells with it. Those read their model files
in the task: the files must be on every node at the same (absolute) path, unlike collection.

Every node needs this project installed (the same environment as the driver).
"""

from __future__ import annotations

import shutil
import tempfile
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dlo_env.atomic import atomic_path

try:
    import fcntl
except ImportError:  # Windows: killed workers' folders stay
    fcntl = None  # type: ignore[assignment]


@dataclass(frozen=True)
class RayBackend:
    """Where and how the chunks run.

    Attributes:
        address: Address of a running Ray cluster (``"auto"``, ``"ray://HOST:10001"``, ...);
            None starts a local Ray runtime for the run, unless one is already initialised.
        num_cpus: CPUs of the local runtime (None: all of this machine's); ignored with an
            address.
        max_retries: Times Ray runs a chunk again after its worker died.
    """

    address: str | None = None
    num_cpus: int | None = None
    max_retries: int = 3

    def __post_init__(self) -> None:
        if not (isinstance(self.max_retries, int) and self.max_retries >= 0):
            raise ValueError(f"max_retries must be an int >= 0, got {self.max_retries!r}")
        if self.num_cpus is not None and not (isinstance(self.num_cpus, int)
                                              and self.num_cpus >= 1):
            raise ValueError(f"num_cpus must be an int >= 1 or None, got {self.num_cpus!r}")

    def map(self, function: Callable[..., Any], calls: list[tuple[Any, ...]]
            ) -> Iterator[tuple[int, Any]]:
        """Run ``function(*args)`` for every ``args`` of ``calls`` as Ray tasks (one CPU each);
        yield ``(index into calls, result)`` as each finishes.

        A task whose worker dies is run again (``max_retries``); its result is yielded once.
        Interrupting the iteration cancels the tasks still running.
        """
        import ray

        started_here = not ray.is_initialized()
        if started_here:
            options = {} if self.address else {"num_cpus": self.num_cpus}
            ray.init(address=self.address, include_dashboard=False, logging_level="warning",
                     **options)
        pending: dict[Any, int] = {}
        try:
            task = ray.remote(num_cpus=1, max_retries=self.max_retries)(function)
            pending = {task.remote(*args): i for i, args in enumerate(calls)}
            while pending:
                done, _ = ray.wait(list(pending), num_returns=1)
                for ref in done:
                    index = pending.pop(ref)
                    try:
                        result = ray.get(ref)
                    except ray.exceptions.RayTaskError as exc:
                        # The task's own exception, so its one-line message reaches the user.
                        raise (exc.cause if exc.cause is not None else exc) from None
                    yield index, result
        finally:
            for ref in pending:
                ray.cancel(ref)
            if started_here:
                ray.shutdown()

    def run(self, job: Any, todo: list[tuple[int, int]], parts: Path,
            progress: Any = None) -> None:
        """Make the chunks ``todo`` (``(index, size)`` pairs) of ``job`` into ``parts``.

        ``progress(done, 0)`` is told a chunk's size when it is written.
        """
        from dlo_env.dataset.chunks import chunk_path

        for k, data in self.map(make_chunk_bytes, [(job, i, n) for i, n in todo]):
            index, size = todo[k]
            with atomic_path(chunk_path(parts, index)) as tmp:
                tmp.write_bytes(data)
            if progress is not None:
                progress(size, 0)


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
