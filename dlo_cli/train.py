"""``dlo train``: train the GAN and the Encoder on a shape dataset (resumable)."""

from __future__ import annotations

import argparse

from dlo_cli.flags import (
    add_device,
    add_seed,
    number_in,
    positive_float,
    positive_int,
    writable_folder,
)

non_negative_int = number_in(int, 0, expected="an integer >= 0")
non_negative_float = number_in(float, 0.0, expected="a number >= 0")

#: Flags that only one kind of stage reads: "transition", or "shape" (gan, encoder, all).
#: Given to the other kind they would be silently ignored, so they are an error there.
STAGE_FLAGS = {
    "transition": ("steps", "members", "architecture", "depth", "cord_inputs", "rim_reach",
                   "peg_reach", "contact_reach", "init",
                   "teacher", "mean_by_grasp", "teacher_weight", "teacher_moves",
                   "miss_weight", "miss_margin", "lr"),
    "shape": ("minutes", "gan_steps", "encoder_steps", "representation", "output", "paper",
              "d_steps", "report_size"),
}
#: Defaults of the shape stages' flags that are None on the command line (so that giving one
#: with --stage transition can be told apart from leaving it).
SHAPE_DEFAULTS = {"minutes": 30.0, "report_size": 2000}
#: Printed after Ctrl-C.
ON_INTERRUPT = ("the same command, run again, continues from the last checkpoint in --out "
                "(written at every evaluation)")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Flags of ``dlo train``; model and training flags map onto the config dataclasses."""
    parser.add_argument("--data", required=True, nargs="+",
                        help="training data: shape files (.npz from dlo collect), or "
                             "transition files (dlo collect --kind transitions) for --stage "
                             "transition; several are joined")
    parser.add_argument("--out", required=True, help="output folder (resumes if it holds a run)")
    parser.add_argument("--heldout", default=None, nargs="+",
                        help="held-out data collected with other seeds, one or several files "
                             "(several are joined; None: 5%% of --data)")
    parser.add_argument("--stage", choices=("gan", "encoder", "all", "transition"), default="all",
                        help="what to train: gan, encoder, all (the shape model), or transition "
                             "(the transition model, on transition data)")
    parser.add_argument("--steps", type=positive_int, default=None,
                        help="--stage transition: optimiser steps (None: TransitionTrainConfig's)")
    parser.add_argument("--members", type=positive_int, default=None,
                        help="--stage transition: networks in the ensemble (None: 5)")
    parser.add_argument("--rim-reach", type=float, default=None,
                        help="--stage transition: metres from the table's edge within which the "
                             "model sees the rim (None: TransitionModelConfig's)")
    parser.add_argument("--contact-reach", type=non_negative_float, default=None,
                        help="--stage transition: a second, sharp rim vector of this reach "
                             "(metres) per point and target, for contact with the walls (0: "
                             "none; None: TransitionModelConfig's); --init from a model without "
                             "it starts their weights at zero; not with --teacher")
    parser.add_argument("--architecture", choices=("mlp", "chain"), default=None,
                        help="--stage transition: the ensemble's design, an MLP on the whole "
                             "chain or a chain-local network (weights shared along the chain, "
                             "latent_model.chain_network; None: TransitionModelConfig's mlp)")
    parser.add_argument("--depth", type=positive_int, default=None,
                        help="--stage transition: hidden layers of the MLP, residual blocks of "
                             "the chain network (None: TransitionModelConfig's)")
    parser.add_argument("--cord-inputs", action="store_true",
                        help="--stage transition: networks that also see each move's cord "
                             "(length, bending stiffness, friction, mass), for data of several "
                             "cords (dlo collect --randomize); predict(params=...) then says "
                             "which cord")
    parser.add_argument("--peg-reach", type=number_in(float, 0.0, 1.0, expected="a number of "
                                                                        "metres in [0, 1]"),
                        default=None, metavar="METRES",
                        help="--stage transition: networks that also see the pegs within this "
                             "of each point and target (TransitionModelConfig.peg_reach), for "
                             "data around pegs (dlo collect --max-pegs); with --init of an MLP "
                             "model without them, their inputs start at zero weight")
    parser.add_argument("--init", default=None,
                        help="--stage transition: start from this transition model file "
                             "(fine-tuning; the same architecture, or an MLP one without the "
                             "contact vectors of --contact-reach, the cord inputs of "
                             "--cord-inputs or the peg vectors of --peg-reach, which start at "
                             "zero weight), "
                             "None: random weights")
    parser.add_argument("--teacher", default=None,
                        help="--stage transition: distil a mean network for this transition "
                             "model file (its ensemble is kept; predict then runs one network)")
    parser.add_argument("--mean-by-grasp", action="store_true",
                        help="--stage transition with --teacher: the mean network is two, one "
                             "for moves of one end and one for moves of both ends (each "
                             "prediction runs one)")
    parser.add_argument("--teacher-weight", type=non_negative_float, default=None,
                        help="--stage transition with --teacher: weight of the error to the "
                             "teacher's mean against the error to the data (None: 1)")
    parser.add_argument("--teacher-moves", type=non_negative_int, default=None,
                        help="--stage transition with --teacher: extra inputs per training "
                             "transition, its start with another transition's move, labelled "
                             "by the teacher's mean alone (None: 0, the data's moves only)")
    parser.add_argument("--miss-weight", type=non_negative_float, default=None,
                        help="--stage transition: extra weight of a move's error beyond "
                             "--miss-margin, so misses count more (None: 0, none)")
    parser.add_argument("--miss-margin", type=non_negative_float, default=None,
                        help="--stage transition: error (metres, mean over points) above which "
                             "--miss-weight applies (None: 0.005)")
    parser.add_argument("--lr", type=positive_float, default=None,
                        help="--stage transition: starting learning rate (None: "
                             "TransitionTrainConfig's; lower it when fine-tuning with --init)")
    parser.add_argument("--minutes", type=non_negative_float, default=None,
                        help="training wall time of the GAN and Encoder, evaluations excluded "
                             f"(None: {SHAPE_DEFAULTS['minutes']:g})")
    parser.add_argument("--gan-steps", type=positive_int, default=None,
                        help="train the GAN for this many generator steps instead of minutes")
    parser.add_argument("--encoder-steps", type=positive_int, default=None,
                        help="train the Encoder for this many steps instead of minutes")
    add_device(parser)
    add_seed(parser, "the training")
    parser.add_argument("--representation", choices=("canonical", "world"), default=None,
                        help="canonical (default) or world (the paper's)")
    parser.add_argument("--output", choices=("angles", "points"), default=None,
                        help="generator output: angles (default, inextensible) or points (paper)")
    parser.add_argument("--paper", action="store_true",
                        help="the paper's recipe: points output, batch 1024, 5 D-steps, Adam "
                             "2e-4, Encoder trained only after the GAN (overridable by the flags)")
    parser.add_argument("--width", type=positive_int, default=None, help="hidden units per layer")
    parser.add_argument("--batch-size", type=positive_int, default=None, help="shapes per batch")
    parser.add_argument("--d-steps", type=positive_int, default=None,
                        help="discriminator steps per generator step")
    parser.add_argument("--threads", type=positive_int, default=None, help="torch CPU threads")
    parser.add_argument("--eval-every", type=positive_int, default=None,
                        help="steps between evaluations")
    parser.add_argument("--report-size", type=positive_int, default=None,
                        help="held-out reference shapes of the shape model's final report "
                             f"(None: {SHAPE_DEFAULTS['report_size']})")
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar")


def check_stage_flags(args: argparse.Namespace) -> None:
    """Refuse a flag the chosen stage would ignore (one line naming it and the stages)."""
    kind = "transition" if args.stage == "transition" else "shape"
    for other, names in STAGE_FLAGS.items():
        # "is not": a flag given as 0 (--miss-weight 0) is given, though 0 == False.
        given = [n for n in names if other != kind
                 and getattr(args, n) is not None and getattr(args, n) is not False]
        if given:
            stages = "--stage transition" if other == "transition" else \
                "--stage gan, encoder or all"
            flag = "--" + given[0].replace("_", "-")
            raise ValueError(f"{flag} applies to {stages} only, not to --stage {args.stage}")


def run(args: argparse.Namespace) -> int:
    """Train, then print the quality report against the floors."""
    check_stage_flags(args)
    for name, value in SHAPE_DEFAULTS.items():
        if getattr(args, name) is None:
            setattr(args, name, value)
    if args.stage == "transition":
        from dlo_cli.train_transition import run as run_transition

        return run_transition(args)
    import json
    import time
    from dataclasses import replace
    from pathlib import Path

    from dlo_env.core.atomic import write_text_atomic
    from latent_model.config import PAPER_MODEL, PAPER_TRAIN, ModelConfig, TrainConfig
    from latent_model.dataset import load_labelled_shapes, split_heldout
    from latent_model.evaluation import quality_report
    from latent_model.training import CHECKPOINT_FILE, train

    data, _ = load_labelled_shapes(args.data, name="--data")
    groups = None
    if args.heldout is not None:
        heldout, groups = load_labelled_shapes(args.heldout, name="--heldout")
        if heldout.shape[1] != data.shape[1]:
            raise ValueError(f"--heldout holds shapes of {heldout.shape[1]} points, --data of "
                             f"{data.shape[1]}")
    else:
        print("no --heldout file: holding out 5% of --data (near duplicates leak; see README)")
        data, heldout = split_heldout(data, 0.05, args.seed)
    model_kw = {k: v for k, v in {"representation": args.representation, "width": args.width,
                                  "output": args.output,
                                  "n_points": int(data.shape[1])}.items() if v is not None}
    train_kw = {k: v for k, v in {"batch_size": args.batch_size, "d_steps": args.d_steps,
                                  "threads": args.threads, "eval_every": args.eval_every}.items()
                if v is not None}
    base_model, base_train = ModelConfig(), TrainConfig()
    if args.paper:
        base_model, base_train = PAPER_MODEL, PAPER_TRAIN
    model_config = replace(base_model, **model_kw)
    train_config = replace(base_train, **train_kw)
    out = Path(writable_folder(args.out))
    resumed = (out / CHECKPOINT_FILE).exists()
    print(f"{'resuming' if resumed else 'training'} in {out}: {len(data)} training shapes, "
          f"{len(heldout)} held-out shapes\n{model_config}\n{train_config}")
    start = time.perf_counter()
    model = train(
        data, heldout, out, model_config, train_config,
        stage=args.stage, minutes=args.minutes, gan_steps=args.gan_steps,
        encoder_steps=args.encoder_steps, device=args.device, seed=args.seed,
        data_info={"data": list(args.data), "heldout": args.heldout and list(args.heldout),
                   "n_train": len(data)},
        progress_bar=not args.no_progress,
    )
    print(f"trained in {(time.perf_counter() - start) / 60:.1f} min (wall, with evaluations); "
          f"model: {out / 'model.pt'}, curves: {out / 'metrics.csv'}, {out / 'metrics.png'}")
    size = min(args.report_size, len(heldout) // 3)
    report = quality_report(model, heldout, n_reference=size, n_inversion=min(size, 1000),
                            seed=args.seed, groups=groups)
    print(report.format())
    write_text_atomic(out / "report.json", json.dumps(report.as_dict(), indent=2))
    return 0
