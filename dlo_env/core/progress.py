"""Progress bars: tqdm on a terminal when it is installed (the ``model`` and ``rl`` extras),
else a plain line on stderr every tenth of the way: the core install runs everything it can,
and a log that output is piped to gets ten lines, not a bar redrawn every few seconds."""

from __future__ import annotations

import sys
from typing import Any


class _Lines:
    """The few members of ``tqdm`` the commands use, printing a line per tenth."""

    def __init__(self, total: int, desc: str, unit: str, initial: int = 0) -> None:
        self.total, self.desc, self.unit = total, desc, unit
        self.n, self._postfix = initial, ""
        self._printed = 10 * initial // max(total, 1)

    def update(self, n: int = 1) -> None:
        self.n += n
        tenth = 10 * self.n // max(self.total, 1)
        if tenth > self._printed:
            self._printed = tenth
            print(f"{self.desc}: {self.n}/{self.total} {self.unit}s {self._postfix}".rstrip(),
                  file=sys.stderr, flush=True)

    def set_postfix_str(self, text: str, refresh: bool = True) -> None:
        self._postfix = text

    def set_postfix(self, **values: Any) -> None:
        self._postfix = ", ".join(f"{k}={v}" for k, v in values.items())

    def refresh(self) -> None:
        """Print when ``n`` (set directly) passed another tenth."""
        self.update(0)

    def write(self, text: str) -> None:
        print(text, file=sys.stderr, flush=True)

    def close(self) -> None:
        pass


class _Quiet(_Lines):
    """No output at all (``progress_bar(..., enabled=False)``)."""

    def update(self, n: int = 1) -> None:
        self.n += n

    def write(self, text: str) -> None:
        print(text, flush=True)


def progress_bar(total: int, desc: str, unit: str, initial: int = 0,
                 enabled: bool = True) -> Any:
    """A progress bar over ``total`` units: ``update(n)``, ``set_postfix_str``, ``write``,
    ``close``. A tqdm bar when stderr is a terminal, else a line every tenth of the way;
    nothing with ``enabled`` False (``write`` then prints to stdout)."""
    if not enabled:
        return _Quiet(total, desc, unit, initial)
    try:
        from tqdm import tqdm
    except ModuleNotFoundError:
        return _Lines(total, desc, unit, initial)
    if not sys.stderr.isatty():
        return _Lines(total, desc, unit, initial)
    return tqdm(total=total, initial=initial, unit=unit, desc=desc, dynamic_ncols=True,
                mininterval=1.0)
