"""Entry point of the ``dlo`` command.

Each subcommand lives in its own module of this package, which provides
``add_arguments(parser)`` and ``run(args) -> int`` (and may say what to do after Ctrl-C in
``ON_INTERRUPT``, and which flag sets a config field of another name in ``field_flags()``); a
module imports what its job needs inside ``run``, so ``dlo collect shapes`` works on the core
install. ``dlo collect`` and ``dlo train`` group two subcommands each; their 0.2.0 spellings
still work (:mod:`dlo_cli.old_spellings`). Errors a user can act on are turned into one line
by :func:`main` (see :mod:`dlo_cli.errors`); every other exception keeps its traceback.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from importlib import metadata
from typing import NoReturn

from dlo_cli.errors import EXIT_INTERRUPTED, EXIT_USER_ERROR, UsageError, user_error_message
from dlo_cli.flags import HelpFormatter
from dlo_cli.old_spellings import new_spelling

DESCRIPTION = ("dlo: a cord on a table as goal-conditioned Gymnasium environments, a GAN shape "
               "model, latent-space planners and a benchmark. Every command writes under "
               "runs/<command> unless --out says otherwise.")
EPILOG = "Run `dlo COMMAND --help` for a command's flags; docs/cli.md explains them all."

#: command -> (module, one-line help); a command with subcommands names them in a dict instead
#: of a module: {subcommand: (module, one-line help)}.
COMMANDS: dict[str, tuple[str | dict[str, tuple[str, str]], str]] = {
    "demo": ("dlo_cli.demo", "latent-mpc, the latent tree and the straight line on a few tasks "
                             "with the shipped models (start here)"),
    "collect": ({"shapes": ("dlo_cli.collect", "cord-like shapes, the shape model's data"),
                 "transitions": ("dlo_cli.collect_transitions",
                                 "one-move transitions, the transition model's data")},
                "collect cord shapes or one-move transitions from the simulator"),
    "train": ({"shape": ("dlo_cli.train", "the shape model (GAN + encoder) on shapes"),
               "transition": ("dlo_cli.train_transition",
                              "the transition model on transitions")},
              "train the shape model (GAN + encoder) on shapes or the transition model on "
              "transitions"),
    "finetune": ("dlo_cli.finetune", "additional training on shapes the model cannot represent"),
    "evaluate": ("dlo_cli.evaluate", "score agents on random tasks or named suites"),
    "baseline": ("dlo_cli.baseline", "train a Stable-Baselines3 baseline"),
    "distil": ("dlo_cli.distil", "distil latent-mpc into a network by DAgger in the surrogate "
                                 "(the agent latent-mpc-distilled)"),
    "benchmark": ("dlo_cli.benchmark", "run every agent on the test suites, one table"),
    "reference": ("dlo_cli.reference", "the reference errors of a designed suite's test "
                                       "tasks, by a long-budget physics search"),
    "export-minari": ("dlo_cli.export_minari",
                      "write the oracle demonstrations and transition data as Minari datasets"),
}
#: The help of ``--debug``, a flag of ``dlo`` and of every command.
DEBUG_HELP = "show the full traceback of an error instead of one line"


def _version() -> str:
    try:
        return metadata.version("dlo")
    except metadata.PackageNotFoundError:  # run from a source tree that was not installed
        return "unknown (not installed)"


class CommandParser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (:class:`UsageError`), not usage + exit."""

    def error(self, message: str) -> NoReturn:
        """Raise the error as one line naming the command, as :func:`main` prints it."""
        raise UsageError(f"{self.prog}: error: {message}")


def _add_debug(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                        help=DEBUG_HELP)


def flags_of(parser: argparse.ArgumentParser, module: object) -> dict[str, str]:
    """Field or option name -> the flag that sets it: each flag's own name (``grasp_weights``
    -> ``--grasp-weights``), then the module's ``field_flags()`` for the fields named
    otherwise."""
    flags = {}
    for action in parser._actions:  # noqa: SLF001 (argparse has no API to list them)
        names = [o for o in action.option_strings if o.startswith("--")]
        if names and action.dest not in flags:
            flags[action.dest] = names[0]
    return {**flags, **getattr(module, "field_flags", dict)()}


def _add_command(sub: argparse._SubParsersAction, name: str, module_name: str, help_text: str,
                 words: str) -> None:
    """The parser of one command (``words``: its name after ``dlo``)."""
    module = importlib.import_module(module_name)
    p = sub.add_parser(name, help=help_text, description=help_text,
                       formatter_class=HelpFormatter)
    _add_debug(p)
    module.add_arguments(p)
    p.set_defaults(_run=module.run, _on_interrupt=getattr(module, "ON_INTERRUPT", ""),
                   _name=words, _flags=flags_of(p, module))


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with one subparser per command (and per subcommand)."""
    parser = CommandParser(prog="dlo", description=DESCRIPTION, epilog=EPILOG)
    parser.add_argument("--version", action="version", version=f"dlo {_version()}")
    parser.add_argument("--debug", action="store_true", help=DEBUG_HELP)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (target, help_text) in COMMANDS.items():
        if isinstance(target, str):
            _add_command(sub, name, target, help_text, name)
            continue
        group = sub.add_parser(name, help=help_text, description=help_text,
                               formatter_class=HelpFormatter)
        _add_debug(group)
        group.set_defaults(_help=group.print_help)
        inner = group.add_subparsers(metavar="SUBCOMMAND")
        for subname, (module_name, sub_help) in target.items():
            _add_command(inner, subname, module_name, sub_help, f"{name} {subname}")
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the ``dlo`` command line; returns the exit code.

    An error the user can act on (see :mod:`dlo_cli.errors`) prints one line on stderr and
    returns 2; ``--debug`` raises it instead (a bad flag has no traceback worth showing: it is
    always one line). Any other exception propagates with its traceback.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    argv, notice = new_spelling(argv, {name: list(target) for name, (target, _) in
                                       COMMANDS.items() if isinstance(target, dict)})
    if notice:
        print(notice, file=sys.stderr)
    parser = build_parser()
    try:
        args, unknown = parser.parse_known_args(argv)
        if unknown:  # named with the command (argparse's own message names only `dlo`)
            where = f"dlo {getattr(args, '_name', args.command or '')}".rstrip()
            raise UsageError(f"{where}: error: unrecognized arguments: {' '.join(unknown)}")
    except UsageError as exc:  # a bad command line: one line, before any work
        print(exc, file=sys.stderr)
        return EXIT_USER_ERROR
    if not hasattr(args, "_run"):
        getattr(args, "_help", parser.print_help)()
        return EXIT_USER_ERROR
    try:
        return int(args._run(args) or 0)
    except BrokenPipeError:  # the reader of our output went away (`dlo ... | head`)
        sys.stdout = open(os.devnull, "w")  # noqa: SIM115 (nothing more is written)
        return 1
    except KeyboardInterrupt:
        if args.debug:
            raise
        hint = getattr(args, "_on_interrupt", "")
        print(f"dlo {args._name}: interrupted{'; ' + hint if hint else ''}", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as exc:
        paths = [value for key, value in vars(args).items() if not key.startswith("_")]
        message = user_error_message(exc, args._flags, paths)
        if message is None or args.debug:
            raise
        print(f"dlo {args._name}: error: {message}", file=sys.stderr)
        return EXIT_USER_ERROR


if __name__ == "__main__":
    sys.exit(main())
