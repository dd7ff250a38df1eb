"""Progress bars: tqdm when it is installed (the ``model`` and ``rl`` extras), else a plain line
on stderr every tenth of the way, so the core install runs everything it can."""

from __future__ import annotations

import sys
from typing import Any


class _Lines:
    """The few members of ``tqdm`` the commands use, printing a line per tenth."""

    def __init__(self, total: int, desc: str, unit: str) -> None:
        self.total, self.desc, self.unit = total, desc, unit
        self.n, self._postfix, self._printed = 0, "", 0

    def update(self, n: int = 1) -> None:
        self.n += n
        tenth = 10 * self.n // max(self.total, 1)
        if tenth > self._printed:
            self._printed = tenth
            print(f"{self.desc}: {self.n}/{self.total} {self.unit}s {self._postfix}".rstrip(),
                  file=sys.stderr, flush=True)

    def set_postfix_str(self, text: str, refresh: bool = True) -> None:
        self._postfix = text

    def close(self) -> None:
        pass


def progress_bar(total: int, desc: str, unit: str) -> Any:
    """A progress bar over ``total`` units: ``update(n)``, ``set_postfix_str``, ``close``."""
    try:
        from tqdm import tqdm
    except ModuleNotFoundError:
        return _Lines(total, desc, unit)
    return tqdm(total=total, unit=unit, desc=desc, dynamic_ncols=True)
