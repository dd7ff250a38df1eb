"""Range checks of configuration fields: the one way a config dataclass rejects a bad value.

Every message has the same form, naming the class, the field, what was expected and what was
given: ``CordParams.length must be > 0, got 0.0``. :func:`all_finite` is the finiteness test of
the few numbers an environment step checks.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from numbers import Integral, Real

import numpy as np

from dlo_env.errors import InputError


def check_fields(config: object, names: tuple[str, ...], ok: Callable[[object], bool],
                 expected: str) -> None:
    """Raise ``InputError`` for the first field of ``names`` whose value fails ``ok``."""
    for name in names:
        value = getattr(config, name)
        if not ok(value):
            raise InputError(f"{type(config).__name__}.{name} must be {expected}, got {value!r}",
                             field=name)


def all_finite(values: np.ndarray) -> bool:
    """Whether every number of ``values`` is finite: ``np.isfinite(values).all()``, in a
    third of its cost for the handful of numbers of an action or a move (numpy's reduction
    machinery outweighs the test itself)."""
    return all(map(math.isfinite, values.ravel().tolist()))


def _number(value: object) -> bool:
    return isinstance(value, Real) and not isinstance(value, bool)


def positive_ints(config: object, *names: str) -> None:
    """Each field is an int >= 1."""
    check_fields(config, names, lambda v: isinstance(v, Integral) and not isinstance(v, bool)
                 and v >= 1, "an int >= 1")


def non_negative_ints(config: object, *names: str) -> None:
    """Each field is an int >= 0."""
    check_fields(config, names, lambda v: isinstance(v, Integral) and not isinstance(v, bool)
                 and v >= 0, "an int >= 0")


def positive(config: object, *names: str) -> None:
    """Each field is a number > 0."""
    check_fields(config, names, lambda v: _number(v) and v > 0, "> 0")


def non_negative(config: object, *names: str) -> None:
    """Each field is a number >= 0."""
    check_fields(config, names, lambda v: _number(v) and v >= 0, ">= 0")


def fractions(config: object, *names: str, closed_low: bool = False) -> None:
    """Each field is in (0, 1] (``[0, 1]`` with ``closed_low``)."""
    low = 0.0
    check_fields(config, names,
                 lambda v: _number(v) and (low <= v if closed_low else low < v) and v <= 1,
                 "in [0, 1]" if closed_low else "in (0, 1]")
