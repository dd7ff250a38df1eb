"""``dlo collect shapes``: collect cord-like shapes from the simulator, the shape model's data.

Also the flags both subcommands of ``dlo collect`` take (:func:`add_common_arguments`).

Example:
    dlo collect shapes --num-shapes 200000 --seed 0 --workers 2 --out data/train.npz
"""

from __future__ import annotations

import argparse
from typing import Any

from dlo_cli.chunked_run import run_chunked
from dlo_cli.flags import (
    add_backend,
    add_seed,
    backend_of,
    engine_text,
    number_in,
    positive_int,
)

_cosine = number_in(float, -1.0, 1.0, expected="a number in [-1, 1]")
#: An argparse type: a share, a number in [0, 1].
share = number_in(float, 0.0, 1.0, expected="a number in [0, 1]")
_weight = number_in(float, 0.0, None, expected="a number >= 0")

#: Flags that set a field of ``CollectConfig`` of the same name (None: the config's default).
CONFIG_FLAGS = ("cosine_threshold", "record_every", "grasp_weights", "push_fraction")


def _npz_path(text: str) -> str:
    if not text.endswith(".npz"):
        raise argparse.ArgumentTypeError(f"expected a file name ending in .npz, got {text!r}")
    return text


def add_common_arguments(parser: argparse.ArgumentParser, config: Any, grasps: str,
                         push: str) -> None:
    """The flags of both subcommands: ``--out``, ``--seed``, ``--workers``, ``--grasp-weights``,
    ``--push-fraction`` (their defaults ``config``'s, their meaning ``grasps`` and ``push``),
    ``--resume`` and the backend's."""
    parser.add_argument("--out", type=_npz_path, required=True, help="dataset file (.npz)")
    add_seed(parser, "the collection (root seed)")
    parser.add_argument("--workers", type=positive_int, default=1,
                        help="worker processes; the arrays do not depend on it")
    parser.add_argument("--grasp-weights", type=_weight, nargs=3, default=None,
                        metavar=("HEAD", "TAIL", "BOTH"),
                        help=f"relative chances of driving the head, the tail or both ends: "
                             f"{grasps} (default "
                             + " ".join(f"{w:g}" for w in config.grasp_weights) + ")")
    parser.add_argument("--push-fraction", type=share, default=None,
                        help="share of moves aimed at the cord's middle, which push it onto "
                             "itself and, with both ends held, compress and buckle it (default "
                             f"{config.push_fraction:g}{push})")
    parser.add_argument("--resume", action="store_true",
                        help="continue an interrupted run from its finished chunks, in the "
                             "folder named --out plus .parts (data/t.npz.parts/)")
    add_backend(parser)


def config_values(args: argparse.Namespace, names: tuple[str, ...]) -> dict[str, Any]:
    """The flags ``names`` the command line gives, as config fields (lists become tuples)."""
    return {name: tuple(value) if isinstance(value, list) else value
            for name in names if (value := getattr(args, name)) is not None}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Flags of ``dlo collect shapes`` (defaults from ``CollectConfig``)."""
    from dlo_env.dataset.collect import CollectConfig

    parser.add_argument("--num-shapes", type=positive_int, required=True,
                        help="cord-like shapes to collect")
    add_common_arguments(parser, CollectConfig, "of each move (head or tail > 0)",
                         " per driven end")
    parser.add_argument("--cosine-threshold", type=_cosine, default=None,
                        help="cord-like filter, least cosine of consecutive segments (default "
                             f"{CollectConfig.cosine_threshold:g})")
    parser.add_argument("--record-every", type=positive_int, default=None,
                        help="record a shape every K physics substeps (default "
                             f"{CollectConfig.record_every}: about 1 cm of motion)")


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
    from dlo_env.dataset.collect import CollectConfig, collect
    from dlo_env.dataset.diversity import diversity_report

    config = CollectConfig(seed=args.seed, **config_values(args, CONFIG_FLAGS))
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
