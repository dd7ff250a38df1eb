"""``dlo collect --kind transitions``: one-move transitions for the transition model.

Example:
    dlo collect --kind transitions --num-transitions 60000 --workers 2 --out runs/transitions.npz
"""

from __future__ import annotations

import argparse

from dlo_cli.flags import backend_of, engine_text


def run(args: argparse.Namespace) -> int:
    """Collect transitions with a progress bar, then print a summary."""
    import os
    import sys
    import time

    import numpy as np

    from dlo_bench.progress import progress_bar
    from dlo_env.dataset.chunks import parts_dir
    from dlo_env.dataset.transitions import (
        GRASP_NAMES,
        TransitionCollectConfig,
        collect_transitions,
    )

    if args.num_transitions is None:
        raise ValueError("--num-transitions is required with --kind transitions")
    config = TransitionCollectConfig(seed=args.seed)
    bars: list = []  # opened on the first report, so argument errors print no bar

    def progress(done: int, rejected: int) -> None:
        if not bars:
            bars.append(progress_bar(args.num_transitions, desc="collect", unit="transition"))
        bars[0].update(done)

    started = time.perf_counter()
    try:
        data = collect_transitions(args.out, args.num_transitions, config,
                                   workers=args.workers, resume=args.resume, progress=progress,
                                   backend=backend_of(args))
    except KeyboardInterrupt:
        print(f"\ninterrupted: finished chunks are kept in {parts_dir(args.out)}; run the "
              "same command with --resume to continue", file=sys.stderr)
        return 130
    finally:
        for bar in bars:
            bar.close()
    elapsed = time.perf_counter() - started
    meta = data.metadata
    made = meta["num_transitions"] - meta["transitions_resumed"]
    print(f"wrote {args.out} ({os.path.getsize(args.out) / 1e6:.1f} MB) in {elapsed:.1f} s")
    if meta["chunks_resumed"]:
        print(f"  resumed {meta['chunks_resumed']} of {meta['chunks']} chunks")
    print(f"  transitions: {len(data)}; {made} made in this run, {made / elapsed:.0f}/s "
          f"{engine_text(args)}; episodes: {meta['episodes']}")
    counts = ", ".join(f"{n} {c}" for n, c in zip(GRASP_NAMES, meta["grasp_counts"]))
    lengths = 100 * np.linalg.norm(data.displacement, axis=-1).max(axis=-1)
    print(f"  grasps: {counts}; move length (cm) 5/50/95 %: "
          + " / ".join(f"{v:.1f}" for v in np.percentile(lengths, [5, 50, 95])))
    print(f"  at rest after the move: {data.at_rest.mean():.1%}; ending within 5 cm of the "
          f"rim: {meta['near_rim']}")
    return 0
