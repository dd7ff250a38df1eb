"""Chunked, parallel, resumable collection: the mechanism every ``dlo collect`` mode shares.

A collection is cut into chunks. Chunk ``i`` draws its randomness from the ``i``-th child of
``SeedSequence(seed)`` (:func:`chunk_rng`), so its content depends neither on timing nor on the
number of workers. Finished chunks are written atomically to ``OUT.parts/`` with a manifest of
the settings; an interrupted run keeps them, and a resumed run (same settings, checked) makes
only the missing ones: nothing is lost and nothing is made twice. Workers are spawned processes.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import signal
import time
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dlo_env.core.atomic import atomic_path, write_text_atomic
from dlo_env.dataset.remote_chunks import make_chunk_bytes
from dlo_env.errors import InputError

#: ``progress(done, rejected)`` receives increments of finished and rejected items.
Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class ChunkJob:
    """One kind of chunked collection.

    Attributes:
        kind: What is collected (``"shapes"``, ``"transitions"``); recorded in the manifest.
        format_version: Version of the chunk files; recorded in the manifest.
        settings: The collection settings as JSON values; a resumed run must match them.
        write: ``write(index, size, path, progress)`` makes chunk ``index`` with ``size`` items
            and saves it to ``path``; a module-level function (workers receive it pickled).
        size_of: ``size_of(path)`` items in a saved chunk; raises ``ValueError`` when the file
            is unreadable (the chunk is then made again).
        defaults: The settings' defaults: a setting that an interrupted run's manifest lacks
            (it predates the setting) counts as its default, which is what the code did then.
    """

    kind: str
    format_version: int
    settings: dict[str, Any]
    write: Callable[[int, int, Path, Progress | None], None]
    size_of: Callable[[Path], int]
    defaults: dict[str, Any] = field(default_factory=dict)


def chunk_plan(total: int, chunk_size: int) -> list[tuple[int, int]]:
    """``(chunk index, items in it)`` for every chunk of a collection of ``total`` items."""
    return [(i, min(chunk_size, total - i * chunk_size))
            for i in range((total + chunk_size - 1) // chunk_size)]


def chunk_rng(seed: int, index: int) -> np.random.Generator:
    """The generator of chunk ``index``: the ``index``-th child of ``SeedSequence(seed)``."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(index,)))


def parts_dir(out: str | os.PathLike[str]) -> Path:
    """Folder holding the finished chunks of an unfinished ``out`` file."""
    out = Path(out)
    return out.with_name(out.name + ".parts")


def chunk_path(parts: Path, index: int) -> Path:
    """File of chunk ``index`` inside ``parts``."""
    return parts / f"chunk-{index:06d}.npz"


def _chunk_ready(job: ChunkJob, parts: Path, index: int, size: int) -> bool:
    path = chunk_path(parts, index)
    if not path.is_file():
        return False
    try:
        return job.size_of(path) >= size
    except ValueError:  # unreadable: make it again
        return False


_worker_queue: Any = None


def _init_worker(queue: Any) -> None:
    global _worker_queue
    _worker_queue = queue
    # Ctrl-C reaches the whole process group: let the parent decide, so running chunks finish
    # and are saved instead of being lost half-way.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # A parent killed outright (SIGTERM, SIGKILL) cannot stop its workers: they stop themselves
    # (their unfinished chunk is made again by the resumed run; finished ones are on disk).
    from dlo_env.core.process_backend import watch_parent

    watch_parent()


def _worker_chunk(job: ChunkJob, index: int, size: int, parts: str) -> int:
    pending = [0, 0]
    last = [time.monotonic()]

    def report(done: int, rejected: int) -> None:
        pending[0] += done
        pending[1] += rejected
        now = time.monotonic()
        if now - last[0] > 0.2:
            _worker_queue.put((pending[0], pending[1]))
            pending[0] = pending[1] = 0
            last[0] = now

    job.write(index, size, chunk_path(Path(parts), index), report)
    _worker_queue.put((pending[0], pending[1]))
    return index


def _drain(queue: Any, progress: Progress | None) -> None:
    while True:
        try:
            done, rejected = queue.get_nowait()
        except Exception:  # queue.Empty, raised under another name by multiprocessing
            return
        if progress is not None:
            progress(done, rejected)


def _run_pool(job: ChunkJob, todo: list[tuple[int, int]], parts: Path, workers: int,
              progress: Progress | None) -> None:
    # spawn: the parent may run threads (progress bar), which fork does not copy safely.
    ctx = multiprocessing.get_context("spawn")
    queue = ctx.Queue()
    executor = ProcessPoolExecutor(max_workers=workers, mp_context=ctx,
                                   initializer=_init_worker, initargs=(queue,))
    try:
        pending = {executor.submit(_worker_chunk, job, i, n, str(parts)) for i, n in todo}
        while pending:
            done, pending = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
            _drain(queue, progress)
            for future in done:
                future.result()
        _drain(queue, progress)
    finally:
        # On an interrupt or error, chunks already running finish and are kept.
        executor.shutdown(wait=True, cancel_futures=True)
        queue.close()


def _check_resumable(job: ChunkJob, parts: Path) -> None:
    manifest = parts / "manifest.json"
    if not manifest.is_file():
        return
    saved = json.loads(manifest.read_text())
    if saved.get("kind", job.kind) != job.kind:
        raise InputError(f"resume: {parts} holds {saved.get('kind')} chunks, not {job.kind}; "
                         "choose another --out or delete the folder")
    if saved.get("format_version") != job.format_version:
        raise InputError(f"resume: {parts} was written by another format version "
                         f"({saved.get('format_version')!r}); delete it to start again")
    old, new = {**job.defaults, **saved.get("collect", {})}, job.settings
    differ = sorted(k for k in set(old) | set(new) if old.get(k) != new.get(k))
    if differ:
        detail = ", ".join(f"{k}: {old.get(k)!r} -> {new.get(k)!r}" for k in differ)
        raise InputError(f"resume: the settings differ from the interrupted run in {parts} "
                         f"({detail}); use the same settings or delete the folder")


def check_out(out: str | os.PathLike[str], *, resume: bool, workers: object) -> Path:
    """Validate an output file name and the leftovers of an earlier run; returns ``out``."""
    if not isinstance(workers, (int, np.integer)) or workers < 1:
        raise InputError(f"workers must be an integer >= 1, got {workers!r}")
    out = Path(out)
    if out.suffix != ".npz":
        raise InputError(f"out must be a .npz file name, got {str(out)!r}")
    if out.exists():
        raise InputError(f"out {str(out)!r} already exists; delete it or choose another file")
    if parts_dir(out).exists() and not resume:
        raise InputError(f"an interrupted run left {str(parts_dir(out))!r}; continue it with "
                         "--resume (resume=True in Python), or delete the folder")
    return out


def _run_on(backend: Any, job: ChunkJob, todo: list[tuple[int, int]], parts: Path,
            progress: Progress | None) -> None:
    """Make the chunks ``todo`` (``(index, size)`` pairs) of ``job`` into ``parts`` as calls of
    ``backend.map``, each returning its chunk's bytes (:func:`make_chunk_bytes`), written here;
    ``progress(done, 0)`` is told a chunk's size when it is written."""
    for k, data in backend.map(make_chunk_bytes, [(job, i, n) for i, n in todo]):
        index, size = todo[k]
        with atomic_path(chunk_path(parts, index)) as tmp:
            tmp.write_bytes(data)
        if progress is not None:
            progress(size, 0)


def run_chunks(job: ChunkJob, out: Path, plan: list[tuple[int, int]], *, workers: int,
               progress: Progress | None, backend: Any = None) -> tuple[Path, int, int]:
    """Make every chunk of ``plan`` that ``OUT.parts/`` does not hold yet.

    ``backend`` (a :class:`dlo_env.core.ray_backend.RayBackend`) runs the chunks elsewhere
    instead of in ``workers`` local processes (:mod:`dlo_env.dataset.remote_chunks`); the
    chunks are the same either way.

    Returns:
        The parts folder, the number of chunks and of items reused from an earlier run.
    """
    parts = parts_dir(out)
    if parts.exists():
        _check_resumable(job, parts)
    parts.mkdir(parents=True, exist_ok=True)
    write_text_atomic(parts / "manifest.json", json.dumps(
        {"kind": job.kind, "format_version": job.format_version, "collect": job.settings},
        indent=1, sort_keys=True))
    todo = [(i, n) for i, n in plan if not _chunk_ready(job, parts, i, n)]
    reused = [(i, n) for i, n in plan if (i, n) not in todo]
    reused_items = sum(n for _, n in reused)
    if progress is not None and reused:
        progress(reused_items, 0)
    if backend is not None:
        _run_on(backend, job, todo, parts, progress)
    elif workers == 1 or len(todo) <= 1:
        for i, n in todo:
            job.write(i, n, chunk_path(parts, i), progress)
    else:
        _run_pool(job, todo, parts, min(workers, len(todo)), progress)
    return parts, len(reused), reused_items
