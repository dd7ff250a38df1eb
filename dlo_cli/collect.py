"""``dlo collect``: collect cord shapes or one-move transitions from the simulator.

Example:
    dlo collect --num-shapes 200000 --seed 0 --workers 2 --out data/train.npz
    dlo collect --kind transitions --num-transitions 60000 --workers 2 --out data/transitions.npz
"""

from __future__ import annotations

import argparse

from dlo_cli.chunked_run import run_chunked
from dlo_cli.flags import (
    add_backend,
    add_seed,
    backend_of,
    engine_text,
    number_in,
    positive_int,
)
from dlo_env.errors import InputError

_cosine = number_in(float, -1.0, 1.0, expected="a number in [-1, 1]")
_share = number_in(float, 0.0, 1.0, expected="a number in [0, 1]")
_weight = number_in(float, 0.0, None, expected="a number >= 0")

#: Flags of ``--kind transitions`` only: fields of ``TransitionCollectConfig`` of the same name.
TRANSITION_FLAGS = ("num_transitions", "wide_fraction", "wavy_fraction", "rim_fraction",
                    "randomize", "test_cords", "max_pegs")
#: Flags of ``--kind shapes`` only: ``num_shapes`` and fields of ``CollectConfig``.
SHAPE_FLAGS = ("num_shapes", "cosine_threshold", "record_every")
#: Flags of both kinds: fields of ``CollectConfig`` and ``TransitionCollectConfig``.
SHARED_FLAGS = ("grasp_weights", "push_fraction")


def _range(text: str) -> tuple[str, tuple[float, float]]:
    """``NAME=LOW:HIGH``: a cord parameter's range."""
    name, _, bounds = text.partition("=")
    low, _, high = bounds.partition(":")
    try:
        return name, (float(low), float(high))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected NAME=LOW:HIGH (e.g. friction=0.2:0.6), "
                                         f"got {text!r}") from None


def _npz_path(text: str) -> str:
    if not text.endswith(".npz"):
        raise argparse.ArgumentTypeError(f"expected a file name ending in .npz, got {text!r}")
    return text


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Flags of ``dlo collect`` (defaults from ``CollectConfig``)."""
    from dlo_env.cord import MAX_PEGS
    from dlo_env.dataset.collect import CollectConfig
    from dlo_env.dataset.transitions import TransitionCollectConfig

    parser.add_argument("--kind", choices=("shapes", "transitions"), default="shapes",
                        help="what to collect: cord-like shapes (shape-model data) or one-move "
                             "transitions (transition-model data)")
    parser.add_argument("--num-shapes", type=positive_int, default=None,
                        help="cord-like shapes to collect (--kind shapes)")
    parser.add_argument("--num-transitions", type=positive_int, default=None,
                        help="transitions to collect (--kind transitions)")
    parser.add_argument("--out", type=_npz_path, required=True, help="dataset file (.npz)")
    add_seed(parser, "the collection (root seed)")
    parser.add_argument("--workers", type=positive_int, default=1,
                        help="worker processes; the arrays do not depend on it")
    parser.add_argument("--cosine-threshold", type=_cosine, default=None,
                        help="--kind shapes: cord-like filter, least cosine of consecutive "
                             f"segments (default {CollectConfig.cosine_threshold:g})")
    parser.add_argument("--record-every", type=positive_int, default=None,
                        help="--kind shapes: record a shape every K physics substeps (default "
                             f"{CollectConfig.record_every}: about 1 cm of motion)")
    parser.add_argument("--wide-fraction", type=_share, default=None,
                        help="--kind transitions: share of episodes starting from a shape of "
                             "wide_cord_shape (several bends, kinks; default "
                             f"{TransitionCollectConfig.wide_fraction:g}; starts of neither "
                             "option are the environments' random starts)")
    parser.add_argument("--wavy-fraction", type=_share, default=None,
                        help="--kind transitions: share of episodes starting from a shape of "
                             "wavy_cord_shape (smooth, bent both ways and several times; "
                             f"default {TransitionCollectConfig.wavy_fraction:g}; with "
                             "--wide-fraction at most 1)")
    parser.add_argument("--grasp-weights", type=_weight, nargs=3, default=None,
                        metavar=("HEAD", "TAIL", "BOTH"),
                        help="relative chances of driving the head, the tail or both ends: of "
                             "each move for shapes (head or tail > 0), of each episode for "
                             "transitions (default: shapes " + " ".join(
                                 f"{w:g}" for w in CollectConfig.grasp_weights) + ", transitions "
                             + " ".join(f"{w:g}" for w in TransitionCollectConfig.grasp_weights)
                             + ")")
    parser.add_argument("--rim-fraction", type=_share, default=None,
                        help="--kind transitions: share of moves aimed at the nearest table edge "
                             f"(default {TransitionCollectConfig.rim_fraction:g}; with "
                             "--push-fraction at most 1)")
    parser.add_argument("--push-fraction", type=_share, default=None,
                        help="share of moves aimed at the cord's middle, which push it onto "
                             "itself and, with both ends held, compress and buckle it (default: "
                             f"shapes {CollectConfig.push_fraction:g} per driven end, transitions "
                             f"{TransitionCollectConfig.push_fraction:g}, with --rim-fraction at "
                             "most 1)")
    parser.add_argument("--randomize", type=_range, nargs="+", default=None,
                        metavar="NAME=LOW:HIGH",
                        help="--kind transitions: draw every episode's cord, NAME one of length, "
                             "bending_stiffness, friction, mass (dlo_env.randomize; each "
                             "transition records its cord)")
    parser.add_argument("--test-cords", action="store_true", default=None,
                        help="--kind transitions: every episode's cord is one of the held-out "
                             "test cords (dlo_env.randomize.TEST_CORDS), to test a model of "
                             "several cords; not with --randomize")
    parser.add_argument("--max-pegs", type=number_in(int, 0, MAX_PEGS, expected="an integer "
                                                     f"from 0 to {MAX_PEGS}"),
                        default=None, metavar="N",
                        help="--kind transitions: every episode places 0 to N pegs near its "
                             "start, and its moves run around them (each transition records "
                             "its pegs; default 0: an empty table)")
    parser.add_argument("--resume", action="store_true",
                        help="continue an interrupted run from its finished chunks, in the "
                             "folder named --out plus .parts (data/t.npz.parts/)")
    add_backend(parser)


def refuse_other_kind(args: argparse.Namespace, flags: tuple[str, ...], kind: str) -> None:
    """One line naming the first of ``flags`` given: it applies to ``--kind kind`` only."""
    for flag in flags:
        if getattr(args, flag) is not None:
            raise InputError(f"--{flag.replace('_', '-')} applies to --kind {kind} only, not to "
                             f"--kind {args.kind}")


class RejectedShare:
    """Progress-bar text: the share of shapes rejected so far."""

    def __init__(self) -> None:
        self.accepted = self.rejected = 0

    def __call__(self, accepted: int, rejected: int) -> str:
        self.accepted += accepted
        self.rejected += rejected
        return f"rejected {self.rejected / max(self.accepted + self.rejected, 1):.1%}"


def run(args: argparse.Namespace) -> int:
    """Collect the dataset with a progress bar, then print a summary."""
    if args.kind == "transitions":
        from dlo_cli.collect_transitions import run as run_transitions

        return run_transitions(args)
    if args.num_shapes is None:
        raise InputError("--num-shapes is required with --kind shapes")
    refuse_other_kind(args, TRANSITION_FLAGS, "transitions")

    from dlo_env.dataset.collect import CollectConfig, collect
    from dlo_env.dataset.diversity import diversity_report

    given = {k: getattr(args, k) for k in (*SHAPE_FLAGS[1:], *SHARED_FLAGS)
             if getattr(args, k) is not None}
    try:
        config = CollectConfig(seed=args.seed, **{k: tuple(v) if isinstance(v, list) else v
                                                  for k, v in given.items()})
    except ValueError as exc:  # "grasp_weights must ..." names the flag
        raise InputError(f"--{str(exc).replace('_', '-', 1)}") from None
    rejected_share = RejectedShare()
    result = run_chunked(
        args, lambda progress: collect(args.out, args.num_shapes, config, workers=args.workers,
                                       resume=args.resume, progress=progress,
                                       backend=backend_of(args)),
        args.num_shapes, "shape", postfix=rejected_share)
    if result is None:
        return 130
    data, elapsed = result
    meta = data.metadata
    rejected = meta["rejected"]
    seen = meta["accepted"] + rejected["total"]
    made = meta["accepted"] - meta["shapes_resumed"]
    print(f"  shapes: {meta['accepted']} accepted; {made} made in this run, "
          f"{made / elapsed:.0f}/s {engine_text(args)}")
    print(f"  rejected: {rejected['total']} ({rejected['total'] / max(seen, 1):.2%}): "
          f"{rejected['cosine']} not cord-like (cosine < {config.cosine_threshold}), "
          f"{rejected['stretch']} stretched > {config.max_stretch:.0%}")
    print(f"  moves (transitions): {meta['moves']}, of which "
          f"{int(data.transition_cord_like.sum())} cord-like at both ends; "
          f"start shapes: {meta['episodes']}")
    for line in diversity_report(data.shapes).lines():
        print(f"  {line}")
    return 0
