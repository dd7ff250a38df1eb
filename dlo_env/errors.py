"""The project's one input-error type, after Gymnasium's ``gymnasium.error``.

Every validator of the project raises :class:`InputError` for bad input: a config dataclass's
checks, an environment's options and constructor arguments, a command-line flag, a file
loader given a missing, corrupt or wrongly formatted file. Its message names the argument,
what was expected and what was given. The ``dlo`` command prints it in one line and exits with
status 2; any other exception is a bug and keeps its traceback.

It subclasses ``ValueError``, so code written against ``except ValueError`` keeps working.
This module imports nothing from the project, so every package can import it.
"""

from __future__ import annotations

__all__ = ["InputError", "MissingFileError"]


class InputError(ValueError):
    """Bad input: raised by every validator, printed by the ``dlo`` command in one line (exit 2).

    Args:
        message: One line naming the argument, what was expected and what was given.
        field: The argument the message is about (a config field, an option, a parameter),
            or several of them; the ``dlo`` command names the flag that sets it.

    Attributes:
        fields: The names ``field`` gave, as a tuple (empty when it gave none).
    """

    def __init__(self, message: str, *, field: str | tuple[str, ...] | None = None) -> None:
        super().__init__(message)
        self.fields: tuple[str, ...] = (field,) if isinstance(field, str) else tuple(field or ())


class MissingFileError(InputError, FileNotFoundError):
    """A file or folder the caller named does not exist (or holds no file of the kind asked
    for). Also a ``FileNotFoundError``, so ``except FileNotFoundError`` catches it."""
