"""A progress bar that needs nothing beyond the core install.

tqdm draws it when installed (the ``model`` and ``rl`` extras bring it); otherwise a plain
line is rewritten on stderr, so ``dlo collect`` runs on the core install.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager


@contextmanager
def progress_bar(total: int, unit: str, desc: str) -> Iterator[Callable[[int], None]]:
    """Yield ``update(n)``; the bar opens on the first update and closes on exit."""
    state: dict[str, object] = {}

    def update(n: int) -> None:
        if "bar" not in state:
            try:
                from tqdm import tqdm
            except ModuleNotFoundError:
                state["bar"] = None
                state["done"], state["last"] = 0, 0.0
            else:
                state["bar"] = tqdm(total=total, unit=unit, desc=desc, dynamic_ncols=True)
        bar = state["bar"]
        if bar is not None:
            bar.update(n)  # type: ignore[attr-defined]
            return
        state["done"] = int(state["done"]) + n  # type: ignore[call-overload]
        now = time.monotonic()
        if now - float(state["last"]) > 0.5 or state["done"] >= total:  # type: ignore[arg-type]
            state["last"] = now
            print(f"\r{desc}: {state['done']}/{total} {unit}s", end="", file=sys.stderr)

    try:
        yield update
    finally:
        bar = state.get("bar")
        if bar is not None:
            bar.close()  # type: ignore[attr-defined]
        elif "bar" in state:
            print(file=sys.stderr)
