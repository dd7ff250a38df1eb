"""The flags several commands share, defined once so they read the same everywhere.

Defaults come from the config dataclasses and the agent registry; ``docs/cli.md`` lists them.
Every value a flag takes is checked while the command line is parsed (the argparse ``type`` of
the flag), so a bad one is a one-line error before any work starts.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable, Iterable
from typing import Any

from dlo_bench.evaluation import DEFAULT_EPISODES
from dlo_env.errors import InputError

#: Largest seed: ``numpy.random.seed``, which Stable-Baselines3 calls, takes 32-bit seeds.
MAX_SEED = 2**32 - 1


def number_in(kind: type, low: float | None = None, high: float | None = None,
              expected: str = "", *, low_open: bool = False) -> Callable[[str], Any]:
    """An argparse type: a finite ``kind`` (int or float) in ``[low, high]`` (``(low, high]``
    with ``low_open``), else a message saying what was ``expected``."""

    def parse(text: str) -> Any:
        try:
            value = kind(text)
        except ValueError:
            value = None
        if value is None or not math.isfinite(value) or (low is not None and (
                value <= low if low_open else value < low)) or (
                high is not None and value > high):
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}")
        return value

    return parse


#: An argparse type: an integer >= 1.
positive_int = number_in(int, 1, expected="a positive integer")
#: An argparse type: a number > 0.
positive_float = number_in(float, 0.0, expected="a number > 0", low_open=True)
#: An argparse type: a seed, an integer from 0 to ``MAX_SEED``.
seed_int = number_in(int, 0, MAX_SEED, expected=f"an integer from 0 to {MAX_SEED}")


def env_id_type(accepted: Iterable[str]) -> Callable[[str], str]:
    """An argparse type: one of the environment ids ``accepted``, given in full
    (``dlo_env/DLOEndpoint-v0``), bare (``DLOEndpoint-v0``) or module-qualified as
    ``gymnasium.make`` takes it (``dlo_env:dlo_env/DLOEndpoint-v0``); returns the full id."""
    ids = tuple(accepted)
    names = {i.split("/")[-1]: i for i in ids}

    def parse(text: str) -> str:
        module, sep, rest = text.partition(":")
        full = rest if sep and module == "dlo_env" else text
        if full in ids:
            return full
        if full in names:
            return names[full]
        raise argparse.ArgumentTypeError(
            f"expected one of {', '.join(ids)} (or {', '.join(names)}, or dlo_env:ID), "
            f"got {text!r}")

    return parse


def add_env(parser: argparse.ArgumentParser, default: str | list[str], what: str,
            accepted: Iterable[str] | None = None, dest: str = "env",
            several: bool = False, alias: bool = False) -> None:
    """``--env``: the environment (``several``: one or more), by id or bare name.

    Args:
        parser: The command's parser.
        default: The default id (a list with ``several``).
        what: What the environment is used for, for the help.
        accepted: The ids the command accepts (None: every id of ``dlo_env.envs``).
        dest: Attribute of the parsed flags.
        several: Take one or several ids.
        alias: Also take ``--env-id``, the deprecated name of the flag (hidden from the help).
    """
    if accepted is None:
        from dlo_env.envs import ENVIRONMENTS

        accepted = ENVIRONMENTS
    ids = tuple(accepted)
    kind = env_id_type(ids)
    nargs = "+" if several else None
    parser.add_argument("--env", type=kind, nargs=nargs, default=default, dest=dest,
                        metavar="ENV_ID",
                        help=f"{what}: {' or '.join(ids)} (a bare name such as "
                             f"{ids[0].split('/')[-1]} works too)")
    if alias:
        parser.add_argument("--env-id", type=kind, nargs=nargs, dest=dest,
                            default=argparse.SUPPRESS, help=argparse.SUPPRESS)


def add_episodes(parser: argparse.ArgumentParser, what: str,
                 default: int = DEFAULT_EPISODES) -> None:
    """``--episodes``: episodes of every row of a quick command (``DEFAULT_EPISODES``)."""
    parser.add_argument("--episodes", type=positive_int, default=default, help=what)


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Help with each flag's default stated once: ``(default: X)`` is added only to a help
    that does not already say its default (``default``, or what ``None:`` means), never to an
    on/off flag, a required one or a default of None (the help says what leaving the flag out
    does), and lists read as on the command line (``1 2 3``)."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        default = action.default
        if (default is argparse.SUPPRESS or default is None or action.nargs == 0 or action.required
                or not action.option_strings or "default" in text.lower() or "None:" in text
                or "%(default)" in text):
            return text
        if isinstance(default, (list, tuple)):
            default = " ".join(map(str, default))
        return f"{text} (default: {str(default).replace('%', '%%')})"


def add_out(parser: argparse.ArgumentParser, command: str, what: str) -> None:
    """``--out``: the output folder, ``runs/<command>`` by default (ignored by git)."""
    from dlo_bench.paths import default_out

    parser.add_argument("--out", default=str(default_out(command)), help=f"folder for {what}")


def writable_folder(path: Any, flag: str = "--out") -> Any:
    """Make the output folder ``path`` (and its parents) and check that a file can be written
    in it, before a command starts its work; returns ``path``.

    Raises:
        ValueError: One line naming ``flag``: ``path`` is a file, or cannot be made or
            written (no permission, a read-only or virtual file system).
    """
    from pathlib import Path

    if Path(path).exists() and not Path(path).is_dir():
        raise InputError(f"{flag} must be a folder, got the file {str(path)!r}")
    reason = _cannot_write_in(Path(path))
    if reason:
        raise InputError(f"{flag} must be a folder this user can write, got {str(path)!r} "
                         f"({reason})")
    return path


def writable_file(path: Any, flag: str = "--out") -> Any:
    """``writable_folder`` for the output file ``path``: it is not a folder, and its folder
    can be made and written; returns ``path``."""
    from pathlib import Path

    if Path(path).is_dir():
        raise InputError(f"{flag} must be a file name, got the folder {str(path)!r}")
    reason = _cannot_write_in(Path(path).parent)
    if reason:
        raise InputError(f"{flag} must be a file in a folder this user can write, got "
                         f"{str(path)!r} ({reason})")
    return path


def _cannot_write_in(folder: Any) -> str:
    """Make ``folder`` and a file in it (removed at once); why that failed, "" if it did not."""
    import os
    import tempfile

    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(dir=folder, prefix=".dlo-write-check-")
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        return exc.strerror or str(exc)
    return ""


def existing_path(what: str) -> Callable[[str], str]:
    """An argparse type: a file or folder that exists, else a message naming ``what``."""

    def parse(text: str) -> str:
        from pathlib import Path

        if not Path(text).exists():
            raise argparse.ArgumentTypeError(f"no {what} file or folder at {text!r}")
        return text

    return parse


def add_model(parser: argparse.ArgumentParser) -> None:
    """``--model``: the shape model of the latent-tree agents."""
    parser.add_argument("--model", type=existing_path("shape model"), default=None,
                        help="shape model file, or folder holding model.pt, for the latent-tree "
                             "agents (None: the shipped latent_model/pretrained/model.pt)")


def add_transition_model(parser: argparse.ArgumentParser) -> None:
    """``--transition-model``: the transition model of latent-mpc and latent-tree-kino."""
    parser.add_argument("--transition-model", type=existing_path("transition model"),
                        default=None,
                        help="transition model file, or folder holding transition.pt, for "
                             "latent-mpc and latent-tree-kino (None: the shipped "
                             "latent_model/pretrained/transition.pt)")


def agent_type(sb3: bool = True) -> Callable[[str], str]:
    """An argparse type: a registered agent name, or (``sb3``) ``sb3:PATH``."""

    def parse(text: str) -> str:
        from dlo_bench.agents import AGENTS, agent_spec

        if not sb3 and text not in AGENTS:
            raise argparse.ArgumentTypeError(
                f"agent name must be one of {', '.join(AGENTS)}, got {text!r}")
        try:
            spec = agent_spec(text)
            folder = spec.defaults.get("baseline")
            if folder is not None:  # sb3:PATH: the folder is read before any work starts
                from dlo_bench.sb3_models import find_sb3

                find_sb3(folder)
        except (ValueError, FileNotFoundError) as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
        return text

    return parse


def add_agent(parser: argparse.ArgumentParser, default: list[str] | None,
              sb3: bool = True) -> None:
    """``--agent``: one or several registered agent names (``sb3``: or ``sb3:PATH``)."""
    from dlo_bench.agents import AGENTS, SB3_PREFIX

    names = "; ".join(f"{name}: {spec.summary}" for name, spec in AGENTS.items())
    folder = (f"; {SB3_PREFIX}PATH: any Stable-Baselines3 model.zip, a folder written by "
              "`dlo baseline`, or an rl-zoo3 run folder" if sb3 else "")
    parser.add_argument("--agent", type=agent_type(sb3), nargs="+", default=default,
                        required=default is None, metavar="AGENT",
                        help=f"one or several agents. {names}{folder}")


def difficulty_type(suites: bool = False, maximum: int | None = None) -> Callable[[str], int]:
    """An argparse type: a task difficulty, 1 to ``maximum`` (default
    ``dlo_env.tasks.MAX_DIFFICULTY``; with ``suites``, one that has a named suite
    ``linear-K``)."""
    from dlo_env.tasks import MAX_DIFFICULTY, SUITES

    if not suites:
        top = maximum or MAX_DIFFICULTY
        return number_in(int, 1, top, expected=f"an integer from 1 to {top}")
    known = sorted(SUITES.values())
    any_int = number_in(int, expected="")
    expected = f"one of {' '.join(map(str, known))} (the suites linear-K)"

    def parse(text: str) -> int:
        try:
            value = any_int(text)
        except argparse.ArgumentTypeError:
            value = None
        if value not in known:
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}")
        return value

    return parse


def add_difficulty(parser: argparse.ArgumentParser | argparse._MutuallyExclusiveGroup,
                   default: list[int] | None, what: str, *, suites: bool = False,
                   maximum: int | None = None, nargs: str = "+") -> None:
    """``--difficulty``: one or several task difficulties (straight moves from start to goal);
    with ``suites``, only those of the named suites; at most ``maximum``; ``nargs="*"``: or
    none."""
    parser.add_argument("--difficulty", type=difficulty_type(suites, maximum), nargs=nargs,
                        default=default, metavar="K",
                        help=f"difficulty, one or several: K straight moves from start to goal; "
                             f"{what}")


def add_seed(parser: argparse.ArgumentParser, what: str, default: int = 0) -> None:
    """``--seed``: an integer from 0 to ``MAX_SEED``."""
    parser.add_argument("--seed", type=seed_int, default=default, help=f"seed of {what}")


def add_planner_flags(parser: argparse.ArgumentParser) -> None:
    """``--replan-every``, ``--max-seconds``, ``--threads`` and ``--no-fidelity``."""
    from dlo_bench.agents import AgentOptions

    parser.add_argument("--replan-every", type=positive_int, default=AgentOptions.replan_every,
                        help="steps between the plan checks of latent-tree-closed")
    parser.add_argument("--max-seconds", type=positive_float, default=AgentOptions.max_seconds,
                        help="time budget of one latent-tree plan, seconds > 0 (None: the "
                             "planner's TreeConfig.max_seconds)")
    add_threads(parser)
    parser.add_argument("--no-fidelity", action="store_true",
                        help="skip the transition fidelity simulation of each first plan")


def device_type(text: str) -> str:
    """An argparse type: a torch device this machine has: ``auto`` (CUDA when available),
    ``cpu``, ``cuda``, ``cuda:N`` or ``mps``."""
    if text in ("auto", "cpu"):
        return text  # no torch import for the defaults
    import torch

    expected = f"expected auto, cpu, cuda, cuda:N or mps, got {text!r}"
    try:
        device = torch.device(text)
    except (RuntimeError, TypeError):
        raise argparse.ArgumentTypeError(expected) from None
    if device.type == "mps" and torch.backends.mps.is_available():
        return text
    if device.type != "cuda":
        raise argparse.ArgumentTypeError(
            expected if device.type != "mps" else f"{text!r}: this PyTorch sees no MPS device")
    if not torch.cuda.is_available():
        raise argparse.ArgumentTypeError(f"{text!r}: this PyTorch sees no CUDA device "
                                         "(torch.cuda.is_available() is False); use cpu or auto")
    if device.index is not None and device.index >= torch.cuda.device_count():
        raise argparse.ArgumentTypeError(f"{text!r}: this machine has "
                                         f"{torch.cuda.device_count()} CUDA device(s)")
    return text


def add_device(parser: argparse.ArgumentParser, default: str = "auto") -> None:
    """``--device``: the torch device of training or inference."""
    parser.add_argument("--device", type=device_type, default=default,
                        help=f"torch device: auto (CUDA when available), cpu, cuda, cuda:N "
                             f"or mps (default {default})")


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
            raise InputError("--address needs --backend ray")
        return None
    from dlo_env.core.ray_backend import RayBackend

    return RayBackend(address=args.address)


def engine_text(args: argparse.Namespace) -> str:
    """How the work ran, for summaries: ``with 2 worker(s)`` or ``on Ray``."""
    return "on Ray" if args.backend == "ray" else f"with {args.workers} worker(s)"
