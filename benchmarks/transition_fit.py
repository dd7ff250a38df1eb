"""Does the transition model underfit? Its one-move error on moves of its own training files
against a file it never saw.

For the shipped predictor (the mean network) and the ensemble's mean: mean error and share
within 1 cm by grasp, on up to ``--sample`` moves drawn from each training file and on the
selection file (collected like the held-out one with seed 4, never trained on). If the shares
on training moves are no better than on unseen ones, the model is limited by what it can fit
(capacity, training), not by the data it has seen.

    python benchmarks/transition_fit.py [--model PATH] [--data FILE ...]
        [--unseen data/transitions-val-4.npz] [--sample 8000]
"""

from __future__ import annotations

import argparse

import numpy as np
import torch

from dlo_env.core.atomic import file_digest
from dlo_env.dataset.transitions import GRASP_NAMES, TransitionDataset, load_transitions
from dlo_env.shapes import error
from latent_model.transition_metrics import cords_of
from latent_model.transition_model import TransitionModel

DEFAULT_DATA = ("data/transitions-train.npz", "data/transitions-train-9.npz",
                "data/transitions-train-11.npz")


def by_grasp(model: TransitionModel, data: TransitionDataset, members: int | None
             ) -> list[str]:
    """``mean (share within 1 cm, moves)`` for each grasp of ``data``."""
    cells = []
    for code, end in enumerate(GRASP_NAMES):
        idx = np.flatnonzero(data.grasp == code)
        if not len(idx):
            cells.append("-")
            continue
        pred = model.predict(data.start[idx], end, data.end_displacement(idx),
                             params=cords_of(model, data, idx), members=members)
        e = error(pred, data.next[idx])
        cells.append(f"{100 * e.mean():.3f} cm ({100 * np.mean(e <= 0.01):.2f} %, {len(idx)})")
    return cells


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default=None, help="transition model (default: shipped)")
    parser.add_argument("--data", nargs="+", default=list(DEFAULT_DATA),
                        help="training files of the model (a sample of each is predicted)")
    parser.add_argument("--unseen", default="data/transitions-val-4.npz",
                        help="a file the model never trained on (dlo collect "
                             "transitions --seed 4)")
    parser.add_argument("--sample", type=int, default=8000, help="moves drawn from each file")
    args = parser.parse_args()
    if args.sample < 1:
        raise SystemExit(f"--sample must be >= 1, got {args.sample}")
    torch.set_num_threads(1)
    model = TransitionModel.load_or_pretrained(args.model, device="cpu")
    # A file is known by its digest, wherever it lies (the model records its sources').
    trained_on = {source.get("digest") for source in model.info.get("sources") or []}
    predictors = {"mean network": None} if model.mean_net is not None else {}
    predictors[f"ensemble ({model.config.members})"] = model.config.members
    print("file | predictor | head / tail / both: mean (within 1 cm, moves)")
    for path in [*args.data, args.unseen]:
        data = load_transitions(path)
        pick = np.random.default_rng(0).permutation(len(data))[:args.sample]
        data = data.subset(np.sort(pick))
        seen = "trained on" if file_digest(path) in trained_on else "not trained on"
        for name, members in predictors.items():
            print(f"{path} ({seen}) | {name} | " + " / ".join(by_grasp(model, data, members)),
                  flush=True)


if __name__ == "__main__":
    main()
