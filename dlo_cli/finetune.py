"""``dlo finetune``: additional training on shapes the model cannot represent (paper VI-C)."""

from __future__ import annotations

import argparse

from dlo_cli.flags import add_device, add_seed, existing_path, positive_int, writable_folder
from dlo_env.errors import InputError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Flags of ``dlo finetune``."""
    parser.add_argument("--model", required=True, type=existing_path("shape model"),
                        help="model folder (holding model.pt) or model.pt file to improve")
    parser.add_argument("--shapes", required=True,
                        help=".npz with a 'shapes' array (N, n, 2) in metres the model should "
                             "represent")
    parser.add_argument("--data", default=None, nargs="+",
                        help="the original training shapes, one or several files (default: the "
                             "files recorded in the model)")
    parser.add_argument("--heldout", default=None, nargs="+",
                        help="held-out shapes to check the metrics did not degrade, one or "
                             "several files (default: the files recorded in the model, when "
                             "they exist)")
    parser.add_argument("--out", default=None,
                        help="output folder for the new model.pt (None: runs/finetune)")
    parser.add_argument("--gan-steps", type=positive_int, default=None,
                        help="GAN steps of the additional training (None: FinetuneConfig's)")
    parser.add_argument("--encoder-steps", type=positive_int, default=None,
                        help="Encoder steps of the additional training (None: FinetuneConfig's)")
    add_seed(parser, "the training")
    parser.add_argument("--report-size", type=positive_int, default=1000,
                        help="held-out reference and inversion shapes per report")
    add_device(parser)
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bars")


def run(args: argparse.Namespace) -> int:
    """Fine-tune, save the new model, print before/after inversion and held-out metrics."""
    import json
    import os
    from dataclasses import replace
    from pathlib import Path

    from dlo_bench.paths import default_out
    from dlo_env.core.atomic import write_text_atomic
    from latent_model import FinetuneConfig, ShapeModel, finetune
    from latent_model.dataset import load_labelled_shapes, load_shapes
    from latent_model.shape_model import MODEL_FILE

    model = ShapeModel.load(args.model, device=args.device, name="--model")
    shapes = load_shapes(args.shapes, name="--shapes")
    def recorded(key: str) -> list[str]:
        # The files a model records: a list, or one path as text (models before several
        # files), "None" when there were none.
        value = model.info.get(key)
        paths = value if isinstance(value, list) else [value] if value else []
        return [p for p in paths if p and p != "None"]

    data_path = args.data or recorded("data")
    if not data_path:
        raise InputError("--data is required: the model does not record its training data file")
    missing = [p for p in data_path if not os.path.exists(p)]
    if missing and not args.data:
        raise InputError(f"--data is required: training data the model records "
                         f"({', '.join(missing)}) is not here; give those shapes, or the "
                         "shapes it should keep representing")
    train_shapes, _ = load_labelled_shapes(data_path, name="--data")
    heldout_path = args.heldout or recorded("heldout")
    heldout = None
    if heldout_path and all(os.path.exists(p) for p in heldout_path):
        heldout, _ = load_labelled_shapes(heldout_path, name="--heldout")
    config = FinetuneConfig()
    steps = {k: v for k, v in {"gan_steps": args.gan_steps,
                               "encoder_steps": args.encoder_steps}.items() if v is not None}
    config = replace(config, **steps)
    out = Path(args.out) if args.out else default_out("finetune")
    if (out / MODEL_FILE).exists():
        raise InputError(f"--out {str(out)!r} holds a model ({MODEL_FILE}), which fine-tuning "
                         "would replace: choose another folder")
    writable_folder(out)
    print(f"fine-tuning {args.model} on {len(shapes)} shapes from {args.shapes}; "
          f"training data {data_path}; held-out {heldout_path if heldout is not None else None}")
    new_model, report = finetune(model, shapes, train_shapes, heldout, config, seed=args.seed,
                                 report_size=args.report_size,
                                 progress_bar=not args.no_progress)
    out.mkdir(parents=True, exist_ok=True)
    new_model.save(out / MODEL_FILE)
    summary = {k: v for k, v in vars(report).items() if not k.startswith("heldout")}
    for key in ("heldout_before", "heldout_after"):
        value = getattr(report, key)
        summary[key] = value.as_dict() if value is not None else None
    write_text_atomic(out / "finetune_report.json", json.dumps(summary, indent=2))
    print(report.format())
    print(f"new model: {out / MODEL_FILE}")
    return 0
