"""``dlo train --stage transition``: train the transition model on transition data (resumable).

Example:
    dlo train --stage transition --data data/transitions-train.npz \
        --heldout data/transitions-heldout.npz --out runs/transition
    dlo train --stage transition --teacher runs/transition/transition.pt --data ... \
        --out runs/transition-mean          # distil a mean network: one network predicts
"""

from __future__ import annotations

import argparse


def run(args: argparse.Namespace) -> int:
    """Train (or resume), then print and write the held-out error report."""
    import time
    from dataclasses import replace
    from pathlib import Path

    import torch

    from dlo_cli.flags import writable_folder
    from dlo_env.core.progress import progress_bar
    from dlo_env.dataset.transitions import (
        load_transition_files,
        split_transitions,
    )
    from latent_model.transition_metrics import report_lines, transition_report, write_report
    from latent_model.transition_model import TransitionModel, TransitionModelConfig
    from latent_model.transition_training import (
        CHECKPOINT_FILE,
        CURVE_FILE,
        TransitionTrainConfig,
        train_transition_model,
    )

    if args.threads:
        torch.set_num_threads(args.threads)
    try:
        data = load_transition_files(args.data)
    except ValueError as exc:
        raise ValueError(f"--data: {exc}") from exc
    if args.heldout is not None:
        try:
            heldout = load_transition_files(args.heldout)
        except ValueError as exc:
            raise ValueError(f"--heldout: {exc}") from exc
        conditioned = args.cord_inputs or bool(
            args.teacher and TransitionModel.load(args.teacher, device="cpu").config.cord_inputs)
        if not conditioned and heldout.one_cord("--heldout") != data.one_cord("--data"):
            raise ValueError("--heldout was collected with another cord than --data")
    else:
        print("no --heldout file: holding out 5% of --data's episodes for the report")
        data, heldout = split_transitions(data, 0.05, seed=args.seed)
    train_kw = {k: v for k, v in {"steps": args.steps, "batch_size": args.batch_size,
                                  "eval_every": args.eval_every, "seed": args.seed,
                                  "init": args.init, "lr": args.lr,
                                  "teacher": args.teacher,
                                  "teacher_weight": args.teacher_weight,
                                  "teacher_moves": args.teacher_moves,
                                  "miss_weight": args.miss_weight,
                                  "miss_margin": args.miss_margin}.items()
                if v is not None}
    model_kw = {k: v for k, v in {"width": args.width, "members": args.members,
                                  "architecture": args.architecture, "depth": args.depth,
                                  "cord_inputs": True if args.cord_inputs else None,
                                  "rim_reach": args.rim_reach,
                                  "contact_reach": args.contact_reach,
                                  "peg_reach": args.peg_reach}.items()
                if v is not None}
    if args.teacher and model_kw:
        given = ", ".join("--" + k.replace("_", "-") for k in model_kw)
        raise ValueError(f"{given} shape a new ensemble, not --teacher's mean network (its "
                         "architecture is the teacher's)")
    if args.mean_by_grasp and not args.teacher:
        raise ValueError("--mean-by-grasp shapes the mean network a distillation makes; it "
                         "needs --teacher")
    if args.teacher:  # what shapes the mean network a distillation makes
        model_kw = {"mean_network": True, "mean_by_grasp": args.mean_by_grasp}
    tc = replace(TransitionTrainConfig(), **train_kw)
    mc = replace(TransitionModelConfig(), **model_kw)
    out = Path(writable_folder(args.out))
    resumed = (out / CHECKPOINT_FILE).exists()
    print(f"{'resuming' if resumed else 'training'} in {out}: {len(data)} transitions, "
          f"{len(heldout)} held out\n{mc if not tc.teacher else 'distilling ' + tc.teacher}"
          f"\n{tc}")
    started = time.perf_counter()
    bar = None if args.no_progress else progress_bar(tc.steps, desc="transition", unit="step")
    done = [0]

    def progress(step: int, stats: dict[str, float]) -> None:
        if bar is not None:
            bar.update(step - done[0])
            done[0] = step

    try:
        model = train_transition_model(data, out, tc, mc, resume=True, device=args.device,
                                       progress=progress)
    finally:
        if bar is not None:
            bar.close()
    print(f"trained in {(time.perf_counter() - started) / 60:.1f} min; model: "
          f"{out / 'transition.pt'}, curve: {out / CURVE_FILE}")
    rows, rank = transition_report(model, heldout)
    for line in report_lines(rows, rank):
        print(line)
    write_report(rows, rank, out)
    print(f"report: {out / 'transition-metrics.csv'}, {out / 'transition-metrics.png'}")
    return 0
