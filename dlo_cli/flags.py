"""The flags several commands share, defined once so they read the same everywhere.

Defaults come from the config dataclasses and the agent registry; ``docs/cli.md`` lists them.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from typing import Any


def number_in(kind: type, low: float | None = None, high: float | None = None,
              expected: str = "") -> Callable[[str], Any]:
    """An argparse type: a finite ``kind`` (int or float) in ``[low, high]``, else a message
    saying what was ``expected``."""

    def parse(text: str) -> Any:
        try:
            value = kind(text)
        except ValueError:
            value = None
        if value is None or not math.isfinite(value) or (low is not None and value < low) or (
                high is not None and value > high):
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}")
        return value

    return parse


#: An argparse type: an integer >= 1.
positive_int = number_in(int, 1, expected="a positive integer")


def add_out(parser: argparse.ArgumentParser, command: str, what: str) -> None:
    """``--out``: the output folder, ``runs/<command>`` by default (ignored by git)."""
    from dlo_bench.paths import default_out

    parser.add_argument("--out", default=str(default_out(command)), help=f"folder for {what}")


def add_model(parser: argparse.ArgumentParser) -> None:
    """``--model``: the shape model of the latent-tree agents."""
    parser.add_argument("--model", default=None,
                        help="shape model file, or folder holding model.pt, for the latent-tree "
                             "agents (None: the shipped latent_model/pretrained/model.pt)")


def add_agent(parser: argparse.ArgumentParser, default: list[str] | None) -> None:
    """``--agent``: one or several registered agent names."""
    from dlo_bench.agents import AGENTS, SB3_PREFIX

    names = "; ".join(f"{name}: {spec.summary}" for name, spec in AGENTS.items())
    parser.add_argument("--agent", nargs="+", default=default, required=default is None,
                        metavar="AGENT",
                        help=f"one or several agents. {names}; {SB3_PREFIX}PATH: a folder written "
                             "by `dlo baseline`")


def add_difficulty(parser: argparse.ArgumentParser | argparse._MutuallyExclusiveGroup,
                   default: list[int] | None, what: str) -> None:
    """``--difficulty``: one or several task difficulties (straight moves from start to goal)."""
    parser.add_argument("--difficulty", type=positive_int, nargs="+", default=default,
                        metavar="K", help=f"difficulty, one or several: K straight moves from "
                                          f"start to goal; {what}")


def add_seed(parser: argparse.ArgumentParser, what: str) -> None:
    """``--seed``."""
    parser.add_argument("--seed", type=int, default=0, help=f"seed of {what}")


def add_planner_flags(parser: argparse.ArgumentParser) -> None:
    """``--replan-every``, ``--max-seconds``, ``--threads`` and ``--no-fidelity``."""
    from dlo_bench.agents import AgentOptions

    parser.add_argument("--replan-every", type=positive_int, default=AgentOptions.replan_every,
                        help="steps between the plan checks of latent-tree-closed")
    parser.add_argument("--max-seconds", type=float, default=AgentOptions.max_seconds,
                        help="time budget of one latent-tree plan, seconds (None: the "
                             "planner's TreeConfig.max_seconds)")
    add_threads(parser)
    parser.add_argument("--no-fidelity", action="store_true",
                        help="skip the transition fidelity simulation of each first plan")


def add_threads(parser: argparse.ArgumentParser, default: int | None = 1) -> None:
    """``--threads``: torch CPU threads."""
    parser.add_argument("--threads", type=positive_int, default=default,
                        help="torch CPU threads (the models are small: more threads mostly "
                             "contend with other work)")


def add_backend(parser: argparse.ArgumentParser,
                local: str = "local worker processes (--workers)") -> None:
    """``--backend`` and ``--address``: ``local`` (what it means for this command), or Ray."""
    parser.add_argument("--backend", choices=("local", "ray"), default="local",
                        help=f"where the work runs: {local}, or Ray (a local Ray runtime, or "
                             "the cluster at --address); the results are the same")
    parser.add_argument("--address", default=None,
                        help="with --backend ray: address of a running Ray cluster ('auto', "
                             "'ray://HOST:10001'); None starts a local Ray runtime")


def backend_of(args: argparse.Namespace) -> Any:
    """The backend the flags of :func:`add_backend` ask for (None: the local process pool)."""
    if args.backend == "local":
        if args.address is not None:
            raise ValueError("--address needs --backend ray")
        return None
    from dlo_env.dataset.ray_backend import RayBackend

    return RayBackend(address=args.address)


def engine_text(args: argparse.Namespace) -> str:
    """How the work ran, for summaries: ``with 2 worker(s)`` or ``on Ray``."""
    return "on Ray" if args.backend == "ray" else f"with {args.workers} worker(s)"
