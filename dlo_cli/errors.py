"""Errors a user can act on: one line on stderr and exit status 2, no traceback.

The ``dlo`` command's one handler (in :mod:`dlo_cli.main`) prints these in one line:

- :class:`dlo_env.errors.InputError`, which every validator raises (a bad flag value, config
  field, option, or a missing, corrupt or foreign file), named by the flag that sets its field;
- a bad command line (:class:`UsageError`, argparse's message);
- a missing optional dependency, with the ``pip install`` that adds it;
- an ``OSError`` about a path the command line names (a flag's value, given or its default):
  the machine refused that file or folder (missing, no permission, a full disk), which no
  traceback helps with.

Every other exception is a bug and keeps its traceback: a ``ValueError`` or ``IndexError`` from
deep in numpy or torch, an ``OSError`` about a file the library chose itself. ``dlo --debug
...`` shows the traceback of every error but a bad command line's (argparse's message is all
there is).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path

from dlo_env.errors import InputError

#: Exit status of a command stopped by bad input (as argparse uses for bad flags).
EXIT_USER_ERROR = 2
#: Exit status after Ctrl-C.
EXIT_INTERRUPTED = 130


class UsageError(InputError):
    """A bad command line (unknown flag, bad value, missing flag): argparse's message, which
    :func:`dlo_cli.main.main` prints as one line instead of argparse's usage and exit."""


#: Optional dependency (its top-level module) -> the extra of ``pyproject.toml`` installing it.
#: A new extra is one entry here.
EXTRAS = {
    "torch": "model",
    "matplotlib": "model",
    "tqdm": "model",
    "stable_baselines3": "rl",
    "pygame": "render",
    "PIL": "render",
    "rl_zoo3": "zoo",
    "yaml": "zoo",
    "minari": "minari",
    "h5py": "minari",
    "ray": "ray",
}


def missing_extra(exc: ModuleNotFoundError) -> str | None:
    """The line for a missing optional dependency, or None if ``exc`` is not about one."""
    module = (exc.name or "").split(".")[0]
    extra = EXTRAS.get(module)
    if extra is None:
        return None
    return (f"this needs {module}, which the core install leaves out: "
            f'pip install "dlo[{extra}]" (in a clone: pip install -e ".[{extra}]")')


def input_error_line(exc: InputError, flags: Mapping[str, str]) -> str:
    """The first line of ``exc``, after ``argument FLAG:`` for each of its fields a flag sets.

    Args:
        exc: The input error.
        flags: Field or option name -> the flag of the command that sets it.
    """
    line = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    named = dict.fromkeys(flags[field] for field in exc.fields if field in flags)
    return f"argument {', '.join(named)}: {line}" if named else line


def names_path(filename: object, values: Iterable[object]) -> bool:
    """Whether ``filename`` is one of the paths ``values`` (strings, or lists of them) or lies
    in one of them."""
    try:
        target = Path(str(filename)).resolve()
    except (OSError, RuntimeError, ValueError):
        return False
    for value in values:
        for text in value if isinstance(value, (list, tuple)) else (value,):
            if not isinstance(text, str) or not text:
                continue
            try:
                path = Path(text).resolve()
            except (OSError, RuntimeError, ValueError):
                continue
            if target == path or path in target.parents:
                return True
    return False


def user_error_message(exc: BaseException, flags: Mapping[str, str] | None = None,
                       paths: Iterable[object] = ()) -> str | None:
    """The one line to print for an error the user can fix, or None for a bug.

    Args:
        exc: The exception a command raised.
        flags: Field or option name -> the flag of the command that sets it.
        paths: The values of the command's flags (a path among them is the user's).

    Returns:
        An input error's first line, naming the flag of its field; a missing extra with the
        ``pip install`` that fixes it; the machine's refusal of a path the command line names.
    """
    if isinstance(exc, InputError):
        return input_error_line(exc, flags or {})
    if isinstance(exc, ModuleNotFoundError):
        return missing_extra(exc)
    if isinstance(exc, OSError) and exc.filename is not None and names_path(exc.filename, paths):
        if isinstance(exc, FileNotFoundError):
            return f"no such file or folder: {exc.filename}"
        return f"{exc.filename}: {exc.strerror or exc}"
    return None
