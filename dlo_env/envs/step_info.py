"""The ``info`` dict of a cord environment's ``reset`` and ``step``, with errors computed on read.

Every ``info`` holds the errors of the returned shape against the goal (``error``,
``max_error``, ``direction_free_error``, ``bead_share``). A loop that reads none of them (a
rollout that only looks at rewards and ``is_success``) need not pay for them every step:
:class:`StepInfo` computes them the first time anything reads them, or reads the whole dict.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from dlo_env.envs.goal_api import METRIC_KEYS


class StepInfo(dict):
    """A ``dict`` whose ``goal_api.METRIC_KEYS`` are computed by ``metrics()`` when first read.

    It holds the same keys, in the same order, with the same values as the plain dict
    ``{**head, **metrics(), **later}``; reading a metric, iterating, comparing, printing,
    copying or pickling it computes the metrics first (once). Copies and pickles are plain
    dicts.

    Args:
        head: The items before the metrics (``is_success``, ``at_rest``).
        metrics: Returns the :data:`METRIC_KEYS` items.
    """

    __slots__ = ("_head", "_metrics")

    def __init__(self, head: dict[str, Any] | None = None,
                 metrics: Callable[[], dict[str, Any]] | None = None) -> None:
        super().__init__(head or {})
        self._head = dict.__len__(self)
        self._metrics = metrics

    def _fill(self) -> None:
        """Put the metrics in place (after the head items); no-op once done."""
        metrics, self._metrics = self._metrics, None
        if metrics is None:
            return
        items = list(dict.items(self))
        dict.clear(self)
        dict.update(self, items[: self._head])
        dict.update(self, metrics())
        dict.update(self, items[self._head:])

    def __missing__(self, key: Any) -> Any:
        if self._metrics is not None and key in METRIC_KEYS:
            self._fill()
            return dict.__getitem__(self, key)
        raise KeyError(key)

    def __contains__(self, key: object) -> bool:
        return dict.__contains__(self, key) or (self._metrics is not None
                                                and key in METRIC_KEYS)

    def get(self, key: Any, default: Any = None) -> Any:
        """``info[key]`` if ``key`` is in the dict, else ``default``."""
        if self._metrics is not None and key in METRIC_KEYS:
            self._fill()
        return dict.get(self, key, default)

    def __setitem__(self, key: Any, value: Any) -> None:
        # A new key goes after the metrics, as it would have in a plain dict.
        if self._metrics is not None and key in METRIC_KEYS:
            self._fill()
        dict.__setitem__(self, key, value)

    def clear(self) -> None:
        """Remove every item (the metrics will not be computed)."""
        self._metrics = None
        dict.clear(self)

    def __eq__(self, other: object) -> bool:
        self._fill()
        if isinstance(other, StepInfo):
            other._fill()
        return dict.__eq__(self, other)

    def __ne__(self, other: object) -> bool:
        return not self == other

    __hash__ = None  # type: ignore[assignment]  # mutable, as dict

    def __reduce_ex__(self, protocol: Any) -> tuple:
        # pickle, copy and deepcopy give a plain dict with every item.
        return dict, (list(self.items()),)


def _filled_first(name: str) -> Callable[..., Any]:
    method = getattr(dict, name)

    def call(self: StepInfo, *args: Any, **kwargs: Any) -> Any:
        self._fill()
        return method(self, *args, **kwargs)

    call.__name__ = call.__qualname__ = name
    call.__doc__ = method.__doc__
    return call


# Every other way to see the whole dict, or to change it, computes the metrics first. (A dict
# subclass that overrides ``__iter__`` is merged by ``{**info}`` and ``dict(info)`` through
# ``keys()`` and ``info[key]``, not through its storage.)
for _name in ("__iter__", "__reversed__", "__len__", "__repr__", "__or__", "__ror__", "__ior__",
              "__delitem__", "keys", "values", "items", "copy", "pop",
              "popitem", "setdefault", "update"):
    setattr(StepInfo, _name, _filled_first(_name))
