"""Entry point of the ``dlo`` command.

Each subcommand lives in its own module of this package, which provides
``add_arguments(parser)`` and ``run(args) -> int``. Modules are imported only when their
subcommand runs, so ``dlo collect`` works without torch installed.
"""

from __future__ import annotations

import argparse
import importlib
import sys

#: subcommand -> (module, one-line help)
COMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("dlo_cli.demo", "plan and execute a few tasks with the shipped model (main job)"),
    "collect": ("dlo_cli.collect", "collect a dataset of cord shapes from the simulator"),
    "train": ("dlo_cli.train", "train the GAN and the encoder on a shape dataset"),
    "finetune": ("dlo_cli.finetune", "additional training on shapes the model cannot represent"),
    "evaluate": ("dlo_cli.evaluate", "score an agent on the environment"),
    "baseline": ("dlo_cli.baseline", "train a Stable-Baselines3 baseline"),
    "benchmark": ("dlo_cli.benchmark", "run every agent on the test suites"),
}


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with one subparser per available subcommand."""
    parser = argparse.ArgumentParser(prog="dlo", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (module_name, help_text) in COMMANDS.items():
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if exc.name == module_name:  # not written yet
                continue
            raise
        p = sub.add_parser(name, help=help_text, description=help_text)
        module.add_arguments(p)
        p.set_defaults(_run=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the ``dlo`` command line; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not hasattr(args, "_run"):
        parser.print_help()
        return 2
    return int(args._run(args) or 0)


if __name__ == "__main__":
    sys.exit(main())
