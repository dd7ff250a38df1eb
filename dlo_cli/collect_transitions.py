"""``dlo collect --kind transitions``: one-move transitions for the transition model.

Example:
    dlo collect --kind transitions --num-transitions 60000 --workers 2 --out runs/transitions.npz
"""

from __future__ import annotations

import argparse

from dlo_cli.flags import backend_of, engine_text
from dlo_env.errors import InputError


def run(args: argparse.Namespace) -> int:
    """Collect transitions with a progress bar, then print a summary."""
    import numpy as np

    from dlo_cli.chunked_run import run_chunked
    from dlo_cli.collect import SHAPE_FLAGS, SHARED_FLAGS, TRANSITION_FLAGS, refuse_other_kind
    from dlo_env.dataset.transitions import (
        GRASP_NAMES,
        TransitionCollectConfig,
        collect_transitions,
    )

    if args.num_transitions is None:
        raise InputError("--num-transitions is required with --kind transitions")
    refuse_other_kind(args, SHAPE_FLAGS, "shapes")
    if args.grasp_weights is not None and sum(args.grasp_weights) <= 0:
        raise InputError(f"--grasp-weights must have a positive sum, got {args.grasp_weights}")
    push = TransitionCollectConfig.push_fraction if args.push_fraction is None \
        else args.push_fraction
    rim = TransitionCollectConfig.rim_fraction if args.rim_fraction is None else args.rim_fraction
    if rim + push > 1:
        raise InputError("--rim-fraction and --push-fraction (defaults "
                         f"{TransitionCollectConfig.rim_fraction:g} and "
                         f"{TransitionCollectConfig.push_fraction:g}) must have a sum <= 1, got "
                         f"{rim:g} and {push:g}")
    if (args.wide_fraction or 0) + (args.wavy_fraction or 0) > 1:
        raise InputError("--wide-fraction and --wavy-fraction must have a sum <= 1, got "
                         f"{args.wide_fraction:g} and {args.wavy_fraction:g}")
    if args.test_cords and args.randomize:
        raise InputError("--test-cords and --randomize are two ways to choose the cords; give "
                         "one")
    given = {k: getattr(args, k) for k in (*TRANSITION_FLAGS[1:], *SHARED_FLAGS)
             if getattr(args, k) is not None}
    if "randomize" in given:
        names = [name for name, _ in given["randomize"]]
        if len(set(names)) < len(names):
            raise InputError(f"--randomize names a parameter twice: {' '.join(names)}")
        given["randomize"] = dict(given["randomize"])
    try:
        config = TransitionCollectConfig(seed=args.seed, **{
            k: tuple(v) if isinstance(v, list) else v for k, v in given.items()})
    except ValueError as exc:
        if "randomize" not in str(exc):
            raise
        raise InputError(f"--{exc}") from None
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
