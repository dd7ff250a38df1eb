"""Errors a user can act on: one line on stderr and exit status 2, no traceback.

The ``dlo`` command's one handler (in :mod:`dlo_cli.main`) turns a bad command line, bad input,
missing or corrupt files, and a missing optional dependency into a line that says what to do;
anything else is a bug and keeps its traceback. ``dlo --debug ...`` shows the traceback of every
error but a bad command line's (argparse's message is all there is).
"""

from __future__ import annotations

#: Exit status of a command stopped by bad input (as argparse uses for bad flags).
EXIT_USER_ERROR = 2
#: Exit status after Ctrl-C.
EXIT_INTERRUPTED = 130


class UsageError(Exception):
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


def user_error_message(exc: BaseException) -> str | None:
    """The one line to print for an error the user can fix, or None for a bug.

    Args:
        exc: The exception a command raised.

    Returns:
        A missing extra with the ``pip install`` that fixes it; a missing or unreadable file;
        or the first line of a ``ValueError`` (bad input: the library's messages name the
        argument, what was expected and what was given).
    """
    if isinstance(exc, ModuleNotFoundError):
        return missing_extra(exc)
    if isinstance(exc, FileNotFoundError) and exc.filename is not None:
        return f"no such file or folder: {exc.filename}"
    if isinstance(exc, (OSError, ValueError)) and str(exc):
        return str(exc).strip().splitlines()[0]
    return None
