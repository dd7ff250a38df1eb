"""``dlo collect transitions``: one-move transitions, the transition model's data.

Example:
    dlo collect transitions --num-transitions 60000 --workers 2 --out runs/transitions.npz
"""

from __future__ import annotations

import argparse

from dlo_cli.collect import add_common_arguments, config_values, share
from dlo_cli.flags import backend_of, engine_text, number_in, positive_int
from dlo_env.errors import InputError

#: Flags that set a field of ``TransitionCollectConfig`` of the same name (None: its default).
CONFIG_FLAGS = ("wide_fraction", "wavy_fraction", "rim_fraction", "randomize", "test_cords",
                "max_pegs", "grasp_weights", "push_fraction")


def _range(text: str) -> tuple[str, tuple[float, float]]:
    """``NAME=LOW:HIGH``: a cord parameter's range."""
    name, _, bounds = text.partition("=")
    low, _, high = bounds.partition(":")
    try:
        return name, (float(low), float(high))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected NAME=LOW:HIGH (e.g. friction=0.2:0.6), "
                                         f"got {text!r}") from None


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Flags of ``dlo collect transitions`` (defaults from ``TransitionCollectConfig``)."""
    from dlo_env.cord import MAX_PEGS
    from dlo_env.dataset.transitions import TransitionCollectConfig as Config

    parser.add_argument("--num-transitions", type=positive_int, required=True,
                        help="transitions to collect")
    add_common_arguments(parser, Config, "of each episode", ", with --rim-fraction at most 1")
    parser.add_argument("--wide-fraction", type=share, default=None,
                        help="share of episodes starting from a shape of wide_cord_shape "
                             f"(several bends, kinks; default {Config.wide_fraction:g}; starts "
                             "of neither option are the environments' random starts)")
    parser.add_argument("--wavy-fraction", type=share, default=None,
                        help="share of episodes starting from a shape of wavy_cord_shape "
                             "(smooth, bent both ways and several times; default "
                             f"{Config.wavy_fraction:g}; with --wide-fraction at most 1)")
    parser.add_argument("--rim-fraction", type=share, default=None,
                        help="share of moves aimed at the nearest table edge (default "
                             f"{Config.rim_fraction:g}; with --push-fraction at most 1)")
    parser.add_argument("--randomize", type=_range, nargs="+", default=None,
                        metavar="NAME=LOW:HIGH",
                        help="draw every episode's cord, NAME one of length, "
                             "bending_stiffness, friction, mass (dlo_env.randomize; each "
                             "transition records its cord)")
    parser.add_argument("--test-cords", action="store_true", default=None,
                        help="every episode's cord is one of the held-out test cords "
                             "(dlo_env.randomize.TEST_CORDS), to test a model of several "
                             "cords; not with --randomize")
    parser.add_argument("--max-pegs", type=number_in(int, 0, MAX_PEGS, expected="an integer "
                                                     f"from 0 to {MAX_PEGS}"),
                        default=None, metavar="N",
                        help="every episode places 0 to N pegs near its start, and its moves "
                             "run around them (each transition records its pegs; default 0: "
                             "an empty table)")


def run(args: argparse.Namespace) -> int:
    """Collect transitions with a progress bar, then print a summary."""
    import numpy as np

    from dlo_cli.chunked_run import run_chunked
    from dlo_env.dataset.transitions import (
        GRASP_NAMES,
        TransitionCollectConfig,
        collect_transitions,
    )

    given = config_values(args, CONFIG_FLAGS)
    if "randomize" in given:  # NAME=LOW:HIGH pairs, as the config's dict
        names = [name for name, _ in given["randomize"]]
        if len(set(names)) < len(names):
            raise InputError(f"--randomize names a parameter twice: {' '.join(names)}")
        given["randomize"] = dict(given["randomize"])
    config = TransitionCollectConfig(seed=args.seed, **given)
    result = run_chunked(
        args, lambda progress: collect_transitions(
            args.out, args.num_transitions, config, workers=args.workers, resume=args.resume,
            progress=progress, backend=backend_of(args)),
        args.num_transitions, "transition")
    if result is None:
        return 130
    data, elapsed = result
    meta = data.metadata
    made = meta["num_transitions"] - meta["transitions_resumed"]
    print(f"  transitions: {len(data)}; {made} made in this run, {made / elapsed:.0f}/s "
          f"{engine_text(args)}; episodes: {meta['episodes']}")
    counts = ", ".join(f"{n} {c}" for n, c in zip(GRASP_NAMES, meta["grasp_counts"]))
    lengths = 100 * np.linalg.norm(data.displacement, axis=-1).max(axis=-1)
    print(f"  grasps: {counts}; move length (cm) 5/50/95 %: "
          + " / ".join(f"{v:.1f}" for v in np.percentile(lengths, [5, 50, 95])))
    print(f"  at rest after the move: {data.at_rest.mean():.1%}; ending within 5 cm of the "
          f"rim: {meta['near_rim']}")
    return 0
