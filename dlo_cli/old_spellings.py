"""The command spellings of dlo 0.2.0, still taken until :data:`REMOVED_IN` removes them.

``dlo collect [--kind shapes|transitions]`` is now ``dlo collect shapes|transitions``, and
``dlo train [--stage gan|encoder|all|transition]`` is now ``dlo train shape [--stage
gan|encoder|all]`` or ``dlo train transition``. An old spelling is rewritten to the new one
before the command line is parsed, with a one-line notice on stderr.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

#: The version that stops taking the old spellings.
REMOVED_IN = "0.3.0"

#: Command -> (the flag that chose what it did, the subcommand when the flag names none).
#: A flag value that names a subcommand becomes that subcommand (the flag goes); any other
#: value stays a flag of the default subcommand (``--stage gan`` of ``dlo train shape``).
OLD_SPELLINGS: dict[str, tuple[str, str]] = {
    "collect": ("--kind", "shapes"),
    "train": ("--stage", "shape"),
}


def _flag_value(words: Sequence[str], flag: str) -> tuple[str | None, list[str]]:
    """The value of ``flag`` in ``words`` (``FLAG VALUE`` or ``FLAG=VALUE``; None if absent),
    and ``words`` without it."""
    for k, word in enumerate(words):
        if word == flag and k + 1 < len(words):
            return words[k + 1], [*words[:k], *words[k + 2:]]
        if word.startswith(flag + "="):
            return word.partition("=")[2], [*words[:k], *words[k + 1:]]
    return None, list(words)


def new_spelling(argv: Sequence[str], subcommands: Mapping[str, Sequence[str]]
                 ) -> tuple[list[str], str | None]:
    """``argv`` in the new spelling, and the deprecation notice to print (None: it was new).

    Args:
        argv: The command line after ``dlo``.
        subcommands: Command -> the names of its subcommands.
    """
    argv = list(argv)
    at = next((k for k, word in enumerate(argv) if not word.startswith("-")), None)
    if at is None or argv[at] not in OLD_SPELLINGS:
        return argv, None
    command, words = argv[at], argv[at + 1:]
    names = subcommands[command]
    if not words or words[0] in names or words[0] in ("-h", "--help"):
        return argv, None
    flag, default = OLD_SPELLINGS[command]
    value, rest = _flag_value(words, flag)
    if value in names:
        sub, old, words = value, f"dlo {command} {flag} {value}", rest
    else:
        sub, old = default, f"dlo {command} without a subcommand"
    notice = (f"dlo: `{old}` is deprecated and {REMOVED_IN} removes it: use "
              f"`dlo {command} {sub}`")
    return [*argv[:at], command, sub, *words], notice
