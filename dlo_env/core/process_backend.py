"""Run independent calls in worker processes of this machine (``dlo benchmark --jobs N``).

:class:`ProcessBackend` has the ``map`` of :class:`dlo_env.core.ray_backend.RayBackend`,
so a command that hands its work units (benchmark cells) to a backend runs them on Ray or on
the cores of one machine alike, without Ray installed. The workers are spawned (no state
inherited from the parent) and each runs one call at a time; a worker whose parent has died
(killed, say, by SIGTERM, which runs no clean-up) exits within a second, so no orphan goes on
computing calls nobody reads.
"""

from __future__ import annotations

import multiprocessing
import os
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass
from typing import Any

from dlo_env.errors import InputError

#: Seconds between a worker's checks that its parent is alive.
PARENT_CHECK_SECONDS = 1.0


def _exit_with(parent: int) -> None:
    """End this process when its parent ``parent`` is gone (it is then re-parented)."""
    while os.getppid() == parent:
        time.sleep(PARENT_CHECK_SECONDS)
    os._exit(1)


def watch_parent() -> None:
    """Start a daemon thread that ends this (worker) process when its parent dies: the
    initializer, or part of it, of every worker pool here (benchmark cells, data chunks,
    reference searches)."""
    threading.Thread(target=_exit_with, args=(os.getppid(),), daemon=True).start()


@dataclass(frozen=True)
class ProcessBackend:
    """Calls run in ``workers`` spawned processes of this machine.

    Attributes:
        workers: Worker processes (at most this many calls run at once).
    """

    workers: int

    def __post_init__(self) -> None:
        if not (isinstance(self.workers, int) and not isinstance(self.workers, bool)
                and self.workers >= 1):
            raise InputError(f"workers must be an int >= 1, got {self.workers!r}")

    def map(self, function: Callable[..., Any], calls: list[tuple[Any, ...]]
            ) -> Iterator[tuple[int, Any]]:
        """Run ``function(*args)`` for every ``args`` of ``calls``; yield ``(index into calls,
        result)`` as each finishes. A call's exception is raised here; interrupting the
        iteration cancels the calls not started and waits for the running ones."""
        context = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=self.workers, mp_context=context,
                                 initializer=watch_parent) as pool:
            pending = {pool.submit(function, *args): i for i, args in enumerate(calls)}
            try:
                while pending:
                    done, _ = wait(pending, return_when=FIRST_COMPLETED)
                    for future in done:
                        index = pending.pop(future)
                        yield index, future.result()
            finally:
                for future in pending:
                    future.cancel()
