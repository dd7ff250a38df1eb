"""Old names kept working: a dataclass field renamed, its old name a deprecated alias."""

from __future__ import annotations

import functools
import warnings
from typing import Any, TypeVar

T = TypeVar("T")


def renamed_field(old: str, new: str) -> Any:
    """Class decorator (above ``@dataclass``): ``Cls(old=...)`` sets ``new`` and ``obj.old``
    reads it, both with a ``DeprecationWarning``. ``old`` is not a field, so ``replace``,
    ``asdict`` and ``repr`` know only ``new``."""

    def decorate(cls: type[T]) -> type[T]:
        init = cls.__init__

        @functools.wraps(init)
        def __init__(self: Any, *args: Any, **kwargs: Any) -> None:
            if old in kwargs:
                if new in kwargs:
                    raise ValueError(f"give {cls.__name__}({new}=...) ({old} is its deprecated "
                                     f"name), not both")
                warnings.warn(f"{cls.__name__}({old}=...) is deprecated: use {new}=...",
                              DeprecationWarning, stacklevel=2)
                kwargs[new] = kwargs.pop(old)
            init(self, *args, **kwargs)

        def read(self: Any) -> Any:
            warnings.warn(f"{cls.__name__}.{old} is deprecated: use {new}", DeprecationWarning,
                          stacklevel=2)
            return getattr(self, new)

        cls.__init__ = __init__  # type: ignore[misc]
        setattr(cls, old, property(read, doc=f"Deprecated name of ``{new}``."))
        return cls

    return decorate
