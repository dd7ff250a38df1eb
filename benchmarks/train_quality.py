"""Quality of the surrogate against CPU-minutes of training, for several recipes, in one run.

Each recipe trains from scratch for ``--minutes`` of training time on the same data with the
same seed, evaluating every ``--eval-every`` generator steps on the same random held-out
subsets (``latent_model.dataset.evaluation_subsets``); the table prints every evaluation.

Recipes:
  paper-world      the paper: world coordinates, point output, spacing loss, 5 D-steps, lr 2e-4
  paper-canonical  the same generator in the canonical frame (pose handled analytically)
  default          what ships: canonical frame, angle output, joint reconstruction + prior,
                   batch 256, 2 D-steps, lr 5e-4 with a cosine decay to 0 over the budget
  default-constant-lr  the same with a constant learning rate

A "best" row is the evaluation the GAN stage ends with (it restores its best one).

    python benchmarks/train_quality.py --data data/train.npz --heldout data/heldout.npz \\
        --minutes 4 [--recipes paper-world,paper-canonical,default] [--out runs/train_quality]
"""

from __future__ import annotations

import argparse
import csv
from dataclasses import replace
from pathlib import Path

import torch

from latent_model.config import PAPER_MODEL, PAPER_TRAIN, ModelConfig, TrainConfig
from latent_model.dataset import load_shapes
from latent_model.training import train

RECIPES = {
    "paper-world": (replace(PAPER_MODEL, representation="world"), PAPER_TRAIN),
    "paper-canonical": (PAPER_MODEL, PAPER_TRAIN),
    "default": (ModelConfig(), TrainConfig()),
    "default-constant-lr": (ModelConfig(), replace(TrainConfig(), lr_schedule="constant")),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True)
    parser.add_argument("--heldout", required=True)
    parser.add_argument("--minutes", type=float, default=4.0, help="training minutes per recipe")
    parser.add_argument("--recipes", default=",".join(RECIPES))
    parser.add_argument("--eval-every", type=int, default=500)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--out", default="runs/train_quality")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    data = load_shapes(args.data, name="--data")
    heldout = load_shapes(args.heldout, name="--heldout")
    names = [r for r in args.recipes.split(",") if r]
    unknown = sorted(set(names) - set(RECIPES))
    if unknown:
        raise SystemExit(f"--recipes: unknown {unknown}; expected names from {sorted(RECIPES)}")
    print(f"{'recipe':<25}{'minutes':>8}{'step':>7}{'COV':>7}{'MMD cm':>8}{'1-NNA':>7}"
          f"{'spCV':>8}{'length':>8}{'inv enc':>8}{'inv':>6}")
    for name in names:
        mc, tc = RECIPES[name]
        tc = replace(tc, eval_every=args.eval_every, threads=args.threads)
        out = Path(args.out) / name
        train(data, heldout, out, mc, tc, stage="gan", minutes=args.minutes, device="cpu",
              progress_bar=False)
        with open(out / "metrics.csv") as f:
            for r in csv.DictReader(f):
                label = f"{name} best" if r["stage"] == "gan-best" else name
                print(f"{label:<25}{float(r['train_minutes']):8.2f}{int(r['step']):7d}"
                      f"{float(r['cov']):7.3f}{100 * float(r['mmd']):8.2f}{float(r['nna']):7.3f}"
                      f"{float(r['spacing_cv']):8.4f}{float(r['length']):8.3f}"
                      f"{float(r['inversion_encoder']):8.3f}{float(r['inversion_refined']):6.3f}")
    print("floors: COV >= 0.85, MMD <= 1.5 cm, 1-NNA <= 0.75, spacing CV <= 0.05, length within "
          "3 %, inversion >= 0.95 (paper recipes: Encoder not yet trained at GAN stage)")


if __name__ == "__main__":
    main()
