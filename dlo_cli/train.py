"""``dlo train shape``: train the GAN and the Encoder on a shape dataset (resumable).

Also the flags both subcommands of ``dlo train`` take (:func:`add_common_arguments`).

Example:
    dlo train shape --data data/train.npz --heldout data/heldout.npz --out runs/model
"""

from __future__ import annotations

import argparse

from dlo_cli.flags import (
    add_device,
    add_seed,
    number_in,
    positive_int,
    writable_folder,
)
from dlo_env.errors import InputError

#: An argparse type: an integer >= 0.
non_negative_int = number_in(int, 0, expected="an integer >= 0")
#: An argparse type: a number >= 0.
non_negative_float = number_in(float, 0.0, expected="a number >= 0")

#: Printed after Ctrl-C.
ON_INTERRUPT = ("the same command, run again, continues from the last checkpoint in --out "
                "(written at every evaluation)")


def add_common_arguments(parser: argparse.ArgumentParser, data: str) -> None:
    """The flags of both subcommands: the files (``data``: what ``--data`` holds), the output
    folder, and the training settings both models have."""
    parser.add_argument("--data", required=True, nargs="+",
                        help=f"training data: {data}; several are joined")
    parser.add_argument("--out", required=True, help="output folder (resumes if it holds a run)")
    parser.add_argument("--heldout", default=None, nargs="+",
                        help="held-out data collected with other seeds, one or several files "
                             "(several are joined; None: 5%% of --data)")
    add_device(parser)
    add_seed(parser, "the training")
    parser.add_argument("--width", type=positive_int, default=None, help="hidden units per layer")
    parser.add_argument("--batch-size", type=positive_int, default=None,
                        help="examples per batch")
    parser.add_argument("--threads", type=positive_int, default=None, help="torch CPU threads")
    parser.add_argument("--eval-every", type=positive_int, default=None,
                        help="steps between evaluations")
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Flags of ``dlo train shape``; model and training flags map onto the config dataclasses."""
    add_common_arguments(parser, "shape files (.npz from dlo collect shapes)")
    parser.add_argument("--stage", choices=("gan", "encoder", "all"), default="all",
                        help="what to train: the GAN, the encoder (on a trained GAN), or both")
    parser.add_argument("--minutes", type=non_negative_float, default=30.0,
                        help="training wall time of the GAN and Encoder, evaluations excluded")
    parser.add_argument("--gan-steps", type=positive_int, default=None,
                        help="train the GAN for this many generator steps instead of minutes")
    parser.add_argument("--encoder-steps", type=positive_int, default=None,
                        help="train the Encoder for this many steps instead of minutes")
    parser.add_argument("--representation", choices=("canonical", "world"), default=None,
                        help="canonical (default) or world (the paper's)")
    parser.add_argument("--output", choices=("angles", "points"), default=None,
                        help="generator output: angles (default, inextensible) or points (paper)")
    parser.add_argument("--paper", action="store_true",
                        help="the paper's recipe: points output, batch 1024, 5 D-steps, Adam "
                             "2e-4, Encoder trained only after the GAN (overridable by the flags)")
    parser.add_argument("--d-steps", type=positive_int, default=None,
                        help="discriminator steps per generator step")
    parser.add_argument("--report-size", type=positive_int, default=2000,
                        help="held-out reference shapes of the shape model's final report")


def run(args: argparse.Namespace) -> int:
    """Train, then print the quality report against the floors."""
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
            raise InputError(f"--heldout holds shapes of {heldout.shape[1]} points, --data of "
                             f"{data.shape[1]}")
    else:
        print("no --heldout file: holding out 5% of --data (its near duplicates stay in "
              "training; docs/shape_model.md collects --heldout with a seed of its own)")
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
