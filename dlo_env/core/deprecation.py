"""Old names kept working: a renamed keyword argument or dataclass field, its old name a
deprecated alias."""

from __future__ import annotations

import functools
import inspect
import warnings
from collections.abc import Callable
from typing import Any, TypeVar

from dlo_env.errors import InputError

T = TypeVar("T")
F = TypeVar("F", bound=Callable[..., Any])


def renamed_argument(old: str, new: str, name: str | None = None) -> Callable[[F], F]:
    """Decorator: ``func(old=...)`` passes the value as ``new``, with a ``DeprecationWarning``;
    ``new`` given too (by keyword or position) is a one-line ``ValueError``. ``old`` is not a
    parameter of ``func``. ``name`` is how the messages call ``func`` (default: its qualified
    name, the class's for an ``__init__``)."""

    def decorate(func: F) -> F:
        label = name or func.__qualname__.removesuffix(".__init__")
        parameters = list(inspect.signature(func).parameters)
        position = parameters.index(new) if new in parameters else None

        @functools.wraps(func)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            if old in kwargs:
                if new in kwargs or (position is not None and len(args) > position):
                    raise InputError(f"give {label}({new}=...) ({old} is its deprecated name), "
                                     "not both")
                warnings.warn(f"{label}({old}=...) is deprecated: use {new}=...",
                              DeprecationWarning, stacklevel=2)
                kwargs[new] = kwargs.pop(old)
            return func(*args, **kwargs)

        return wrapper  # type: ignore[return-value]

    return decorate


def renamed_field(old: str, new: str) -> Any:
    """Class decorator (above ``@dataclass``): ``Cls(old=...)`` sets ``new`` and ``obj.old``
    reads it, both with a ``DeprecationWarning``. ``old`` is not a field, so ``replace``,
    ``asdict`` and ``repr`` know only ``new``."""

    def decorate(cls: type[T]) -> type[T]:
        def read(self: Any) -> Any:
            warnings.warn(f"{cls.__name__}.{old} is deprecated: use {new}", DeprecationWarning,
                          stacklevel=2)
            return getattr(self, new)

        cls.__init__ = renamed_argument(old, new, cls.__name__)(cls.__init__)  # type: ignore[misc]
        setattr(cls, old, property(read, doc=f"Deprecated name of ``{new}``."))
        return cls

    return decorate
