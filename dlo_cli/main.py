"""Entry point of the ``dlo`` command.

Each subcommand lives in its own module of this package, which provides
``add_arguments(parser)`` and ``run(args) -> int`` (and may say what to do after Ctrl-C in
``ON_INTERRUPT``); a module imports what its job needs inside
``run``, so ``dlo collect`` works on the core install. Errors a user can act on are turned into
one line by :func:`main` (see :mod:`dlo_cli.errors`): a bad flag value while the command line
is parsed (the flag types of :mod:`dlo_cli.flags`), anything else before the command's work
starts.
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

DESCRIPTION = ("dlo: a cord on a table as goal-conditioned Gymnasium environments, a GAN shape "
               "model, latent-space planners and a benchmark. Every command writes under "
               "runs/<command> unless --out says otherwise.")
EPILOG = "Run `dlo COMMAND --help` for a command's flags; docs/cli.md explains them all."

#: subcommand -> (module, one-line help)
COMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("dlo_cli.demo", "latent-mpc, the latent tree and the straight line on a few tasks "
                             "with the shipped models (start here)"),
    "collect": ("dlo_cli.collect", "collect cord shapes or, with --kind transitions, one-move "
                                   "transitions from the simulator"),
    "train": ("dlo_cli.train", "train the shape model (GAN + encoder) on shapes or, with --stage "
                               "transition, the transition model on transitions"),
    "finetune": ("dlo_cli.finetune", "additional training on shapes the model cannot represent"),
    "evaluate": ("dlo_cli.evaluate", "score agents on random tasks or named suites"),
    "baseline": ("dlo_cli.baseline", "train a Stable-Baselines3 baseline"),
    "benchmark": ("dlo_cli.benchmark", "run every agent on the test suites, one table"),
    "reference": ("dlo_cli.reference", "the reference errors of a designed suite's test "
                                       "tasks, by a long-budget physics search"),
    "export-minari": ("dlo_cli.export_minari",
                      "write the oracle demonstrations and transition data as Minari datasets"),
}


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


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with one subparser per subcommand."""
    parser = CommandParser(prog="dlo", description=DESCRIPTION, epilog=EPILOG)
    parser.add_argument("--version", action="version", version=f"dlo {_version()}")
    parser.add_argument("--debug", action="store_true",
                        help="show the full traceback of an error instead of one line")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (module_name, help_text) in COMMANDS.items():
        module = importlib.import_module(module_name)
        p = sub.add_parser(name, help=help_text, description=help_text,
                           formatter_class=HelpFormatter)
        p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                       help="show the full traceback of an error instead of one line")
        module.add_arguments(p)
        p.set_defaults(_run=module.run, _on_interrupt=getattr(module, "ON_INTERRUPT", ""))
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the ``dlo`` command line; returns the exit code.

    An error the user can act on (a bad flag, bad input, a missing or corrupt file, a missing
    optional dependency) prints one line on stderr and returns 2; ``--debug`` raises it instead
    (a bad flag has no traceback worth showing: it is always one line).
    """
    parser = build_parser()
    try:
        args, unknown = parser.parse_known_args(argv)
        if unknown:  # named with the command (argparse's own message names only `dlo`)
            where = f"dlo {args.command}" if args.command else "dlo"
            raise UsageError(f"{where}: error: unrecognized arguments: {' '.join(unknown)}")
    except UsageError as exc:  # a bad command line: one line, before any work
        print(exc, file=sys.stderr)
        return EXIT_USER_ERROR
    if not hasattr(args, "_run"):
        parser.print_help()
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
        print(f"dlo {args.command}: interrupted{'; ' + hint if hint else ''}", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as exc:
        message = user_error_message(exc)
        if message is None or args.debug:
            raise
        print(f"dlo {args.command}: error: {message}", file=sys.stderr)
        return EXIT_USER_ERROR


if __name__ == "__main__":
    sys.exit(main())
