"""A transition model around pegs: its one-move error on moves that touch a peg and on the rest.

For each model given, the mean one-move error (cm) and the share within 1 cm on a held-out
file collected with ``dlo collect --kind transitions --max-pegs N``, split into the moves that
touch a peg (the cord, before or after, within ``TOUCH`` of a peg's surface, or a gripper
stopped by one) and those that touch none, each by one end (head and tail) and both ends. Every
model is told the move's pegs: one with ``peg_reach`` sees them, every model stops the
grippers at them. The floors of issue 36 (``FLOORS``): moves that touch a peg at most 0.5 cm
mean; moves that touch none within 10 % of the first model's error (give the peg-free model
first).

    python benchmarks/pegs_model.py --model latent_model/pretrained/transition.pt FILE \
        --data data/pegs-heldout-32.npz [--out runs/pegs-model]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch

from dlo_env.atomic import file_digest, write_text_atomic
from dlo_env.cord import peg_clearance
from dlo_env.dataset.transitions import GRASP_NAMES, TransitionDataset, load_transitions
from dlo_env.shapes import error
from latent_model.transition_metrics import cords_of, pegs_of
from latent_model.transition_model import TransitionModel

#: A move touches a peg when the cord, before or after, comes this close to its surface, m.
TOUCH = 0.01
#: Share within this of the observed shape, metres.
WITHIN = 0.01
#: Mean one-move error floor on moves that touch a peg, metres; and the most the error on
#: moves that touch none may exceed the first (peg-free) model's, as a share.
FLOORS = {"touching": 0.005, "untouched_rise": 0.10}


def touching(data: TransitionDataset) -> np.ndarray:
    """``(T,)`` whether each move touches a peg: the cord within ``TOUCH`` of one, before or
    after, or a gripper stopped short of its commanded move."""
    out = np.zeros(len(data), dtype=bool)
    stopped = np.abs(data.moved - data.displacement).max(axis=(1, 2)) > 1e-4
    for i in np.flatnonzero(data.peg_count):
        pegs = data.peg_list(i)
        out[i] = min(peg_clearance(data.start[i], pegs), peg_clearance(data.next[i], pegs)) \
            <= TOUCH
    return out | (stopped & (data.peg_count > 0))


def errors(model: TransitionModel, data: TransitionDataset) -> np.ndarray:
    """``(T,)`` one-move error of ``model`` on every transition, metres."""
    out = np.zeros(len(data))
    for code, name in enumerate(GRASP_NAMES):
        idx = np.flatnonzero(data.grasp == code)
        if len(idx):
            pred = model.predict(data.start[idx], name, data.end_displacement(idx),
                                 params=cords_of(model, data, idx), pegs=pegs_of(data, idx))
            out[idx] = error(pred, data.next[idx])
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", nargs="+", required=True, help="transition model files")
    parser.add_argument("--data", required=True, help="held-out transitions around pegs")
    parser.add_argument("--out", default="runs/pegs-model", help="folder of results.json")
    parser.add_argument("--threads", type=int, default=1, help="torch threads")
    args = parser.parse_args(argv)
    torch.set_num_threads(args.threads)
    data = load_transitions(args.data)
    if not data.peg_count.any():
        parser.error("--data holds no move around a peg: collect it with --max-pegs N")
    touch = touching(data)
    one = data.grasp < 2
    groups = {"touching": touch, "untouched": ~touch}
    print(f"{args.data}: {len(data)} moves, {int(touch.sum())} touch a peg "
          f"({int((data.peg_count > 0).sum())} with pegs on the table)")
    header = f"{'model':>40}  {'moves':>10}  {'one end cm':>10}  {'both cm':>8}  " \
             f"{'all cm':>7}  {'within 1 cm':>11}"
    print(header)
    results: dict[str, dict] = {}
    for path in args.model:
        model = TransitionModel.load(path, device="cpu")
        e = errors(model, data)
        row = {}
        for label, sel in groups.items():
            row[label] = {
                "count": int(sel.sum()),
                "one_end_cm": 100 * float(e[sel & one].mean()) if (sel & one).any() else None,
                "both_cm": 100 * float(e[sel & ~one].mean()) if (sel & ~one).any() else None,
                "mean_cm": 100 * float(e[sel].mean()),
                "within_1cm": float((e[sel] <= WITHIN).mean()),
            }
            r = row[label]
            print(f"{Path(path).name[-40:]:>40}  {label:>10}  {r['one_end_cm'] or 0:10.3f}  "
                  f"{r['both_cm'] or 0:8.3f}  {r['mean_cm']:7.3f}  {r['within_1cm']:11.1%}")
        results[path] = {"digest": file_digest(path)[:16], "peg_reach": model.config.peg_reach,
                         **row}
    first = next(iter(results.values()))
    for path, row in list(results.items())[1:]:
        rise = row["untouched"]["mean_cm"] / first["untouched"]["mean_cm"] - 1
        ok_touch = row["touching"]["mean_cm"] <= 100 * FLOORS["touching"]
        ok_rise = rise <= FLOORS["untouched_rise"]
        print(f"{Path(path).name}: touching {row['touching']['mean_cm']:.3f} cm (floor "
              f"{100 * FLOORS['touching']:.1f}: {'met' if ok_touch else 'NOT met'}); untouched "
              f"{rise:+.1%} against {Path(args.model[0]).name} (floor +"
              f"{FLOORS['untouched_rise']:.0%}: {'met' if ok_rise else 'NOT met'})")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out / "results.json", json.dumps(
        {"data": args.data, "touch_m": TOUCH, "models": results}, indent=2) + "\n")
    print(f"wrote {out / 'results.json'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
