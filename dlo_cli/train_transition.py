"""``dlo train transition``: train the transition model on transition data (resumable).

Example:
    dlo train transition --data data/transitions-train.npz \
        --heldout data/transitions-heldout.npz --out runs/transition
    dlo train transition --teacher runs/transition/transition.pt --data ... \
        --out runs/transition-mean          # distil a mean network: one network predicts
"""

from __future__ import annotations

import argparse

from dlo_cli.flags import number_in, positive_float, positive_int
from dlo_cli.train import (
    ON_INTERRUPT,
    add_common_arguments,
    non_negative_float,
    non_negative_int,
)
from dlo_env.errors import InputError

__all__ = ["ON_INTERRUPT", "add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Flags of ``dlo train transition``; they map onto ``TransitionModelConfig`` and
    ``TransitionTrainConfig``."""
    add_common_arguments(parser, "transition files (.npz from dlo collect transitions)")
    parser.add_argument("--steps", type=positive_int, default=None,
                        help="optimiser steps (None: TransitionTrainConfig's)")
    parser.add_argument("--members", type=positive_int, default=None,
                        help="networks in the ensemble (None: 5)")
    parser.add_argument("--rim-reach", type=float, default=None,
                        help="metres from the table's edge within which the "
                             "model sees the rim (None: TransitionModelConfig's)")
    parser.add_argument("--contact-reach", type=non_negative_float, default=None,
                        help="a second, sharp rim vector of this reach "
                             "(metres) per point and target, for contact with the walls (0: "
                             "none; None: TransitionModelConfig's); --init from a model without "
                             "it starts their weights at zero; not with --teacher")
    parser.add_argument("--architecture", choices=("mlp", "chain"), default=None,
                        help="the ensemble's design, an MLP on the whole "
                             "chain or a chain-local network (weights shared along the chain, "
                             "latent_model.chain_network; None: TransitionModelConfig's mlp)")
    parser.add_argument("--depth", type=positive_int, default=None,
                        help="hidden layers of the MLP, residual blocks of "
                             "the chain network (None: TransitionModelConfig's)")
    parser.add_argument("--cord-inputs", action="store_true",
                        help="networks that also see each move's cord "
                             "(length, bending stiffness, friction, mass), for data of several "
                             "cords (dlo collect transitions --randomize); predict(params=...) "
                             "then says which cord")
    parser.add_argument("--peg-reach", type=number_in(float, 0.0, 1.0, expected="a number of "
                                                                        "metres in [0, 1]"),
                        default=None, metavar="METRES",
                        help="networks that also see the pegs within this "
                             "of each point and target (TransitionModelConfig.peg_reach), for "
                             "data around pegs (dlo collect transitions --max-pegs); with --init "
                             "of an MLP model without them, their inputs start at zero weight")
    parser.add_argument("--init", default=None,
                        help="start from this transition model file "
                             "(fine-tuning; the same architecture, or an MLP one without the "
                             "contact vectors of --contact-reach, the cord inputs of "
                             "--cord-inputs or the peg vectors of --peg-reach, which start at "
                             "zero weight), "
                             "None: random weights")
    parser.add_argument("--teacher", default=None,
                        help="distil a mean network for this transition "
                             "model file (its ensemble is kept; predict then runs one network)")
    parser.add_argument("--mean-by-grasp", action="store_true",
                        help="with --teacher: the mean network is two, one "
                             "for moves of one end and one for moves of both ends (each "
                             "prediction runs one)")
    parser.add_argument("--teacher-weight", type=non_negative_float, default=None,
                        help="with --teacher: weight of the error to the "
                             "teacher's mean against the error to the data (None: 1)")
    parser.add_argument("--teacher-moves", type=non_negative_int, default=None,
                        help="with --teacher: extra inputs per training "
                             "transition, its start with another transition's move, labelled "
                             "by the teacher's mean alone (None: 0, the data's moves only)")
    parser.add_argument("--miss-weight", type=non_negative_float, default=None,
                        help="extra weight of a move's error beyond "
                             "--miss-margin, so misses count more (None: 0, none)")
    parser.add_argument("--miss-margin", type=non_negative_float, default=None,
                        help="error (metres, mean over points) above which "
                             "--miss-weight applies (None: 0.005)")
    parser.add_argument("--lr", type=positive_float, default=None,
                        help="starting learning rate (None: "
                             "TransitionTrainConfig's; lower it when fine-tuning with --init)")


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
    except InputError as exc:
        raise InputError(f"--data: {exc}") from exc
    if args.heldout is not None:
        try:
            heldout = load_transition_files(args.heldout)
        except InputError as exc:
            raise InputError(f"--heldout: {exc}") from exc
        conditioned = args.cord_inputs or bool(
            args.teacher and TransitionModel.load(args.teacher, device="cpu").config.cord_inputs)
        if not conditioned and heldout.one_cord("--heldout") != data.one_cord("--data"):
            raise InputError("--heldout was collected with another cord than --data")
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
        raise InputError(f"{given} shape a new ensemble, not --teacher's mean network (its "
                         "architecture is the teacher's)")
    if args.mean_by_grasp and not args.teacher:
        raise InputError("--mean-by-grasp shapes the mean network a distillation makes; it "
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
