"""Where does the transition model miss? Its misses (one-move error over 1 cm) by grasp and by
how near the cord comes to the table's rim.

Each move is put in a band by the nearest distance of any point of its start or of its result
to the table's edge: under 1 cm (the cord touches a wall; it rests 5 mm inside the edge),
1-5 cm, 5 cm or more. For each grasp and band: moves, misses, their share, the mean error.

    python benchmarks/transition_misses.py [--model PATH] [--members K]
        [--file data/transitions-val-4.npz ...]
"""

from __future__ import annotations

import argparse

import numpy as np

from dlo_cli.flags import positive_int
from dlo_env.dataset.transitions import GRASP_NAMES, load_transitions
from dlo_env.shapes import TABLE_HALF, error
from latent_model.transition_metrics import cords_of
from latent_model.transition_model import TransitionModel

#: Bands of the nearest distance to the rim, metres: [low, high) (every distance is in one).
BANDS = ((-np.inf, 0.01, "under 1 cm"), (0.01, 0.05, "1-5 cm"), (0.05, np.inf, "5 cm or more"))
MISS = 0.01


def rim_distance(*shapes: np.ndarray) -> np.ndarray:
    """``(B,)`` nearest distance of any point of any of the ``(B, n, 2)`` shapes to the edge."""
    return np.min([TABLE_HALF - np.abs(s).max(axis=(1, 2)) for s in shapes], axis=0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default=None, help="transition model file (default: shipped)")
    parser.add_argument("--members", type=positive_int, default=None,
                        help="the mean of the ensemble's first K networks (default: the "
                             "model's own prediction)")
    parser.add_argument("--file", nargs="+", default=["data/transitions-val-4.npz"],
                        help="transition files (default: the seed-4 selection file)")
    args = parser.parse_args()
    model = TransitionModel.load_or_pretrained(args.model, device="cpu")
    for path in args.file:
        data = load_transitions(path)
        print(f"{path}, {args.model or 'shipped model'}"
              f"{'' if args.members is None else f', {args.members} networks'}")
        print(f"   {'grasp':<6} {'nearest edge':<13} {'moves':>6} {'misses':>7} {'share':>7} "
              f"{'mean':>8}")
        for code, end in enumerate(GRASP_NAMES):
            idx = np.flatnonzero(data.grasp == code)
            if not len(idx):
                continue
            pred = model.predict(data.start[idx], end, data.end_displacement(idx),
                                 params=cords_of(model, data, idx), members=args.members)
            e = error(pred, data.next[idx])
            near = rim_distance(data.start[idx], data.next[idx])
            for low, high, label in BANDS + ((-np.inf, np.inf, "all"),):
                band = (near >= low) & (near < high)
                if band.any():
                    miss = e[band] > MISS
                    print(f"   {end:<6} {label:<13} {band.sum():>6} {miss.sum():>7} "
                          f"{100 * miss.mean():>6.2f}% {100 * e[band].mean():>6.3f}cm")


if __name__ == "__main__":
    main()
