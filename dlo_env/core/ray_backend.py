"""Ray as the engine of independent calls, when one machine is not enough.

:meth:`RayBackend.map` runs any function over a list of argument tuples as Ray tasks, one
each, on a local Ray runtime or on the cluster at ``address``; it has the ``map`` of
:class:`dlo_env.core.process_backend.ProcessBackend`. Chunked collection
(:func:`dlo_env.dataset.chunks.run_chunks`) hands it its chunks, the benchmark and
``dlo evaluate`` their cells. A task whose worker dies (killed, node lost) is run again by
Ray (``max_retries``); its result is yielded once. The benchmark's and ``dlo evaluate``'s
tasks read their model files in the task: the files must be on every node at the same
(absolute) path (collection's chunks need no shared file system).

Every node needs this project installed (the same environment as the driver).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

from dlo_env.errors import InputError


@dataclass(frozen=True)
class RayBackend:
    """Where and how the calls run.

    Attributes:
        address: Address of a running Ray cluster (``"auto"``, ``"ray://HOST:10001"``, ...);
            None starts a local Ray runtime for the run, unless one is already initialised.
        num_cpus: CPUs of the local runtime (None: all of this machine's); ignored with an
            address.
        max_retries: Times Ray runs a call again after its worker died.
    """

    address: str | None = None
    num_cpus: int | None = None
    max_retries: int = 3

    def __post_init__(self) -> None:
        if not (isinstance(self.max_retries, int) and self.max_retries >= 0):
            raise InputError(f"max_retries must be an int >= 0, got {self.max_retries!r}")
        if self.num_cpus is not None and not (isinstance(self.num_cpus, int)
                                              and self.num_cpus >= 1):
            raise InputError(f"num_cpus must be an int >= 1 or None, got {self.num_cpus!r}")

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
