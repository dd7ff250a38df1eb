"""A transition model on cords that differ: its one-move error on each held-out test cord.

For each model given, the mean one-move error (cm) and the share within 1 cm of moves of one
end (head and tail) and of both ends, on every cord of a file collected with ``dlo collect
--kind transitions --test-cords`` (the six ``dlo_env.randomize.TEST_CORDS``, which no
cord-conditioned model trains near), and on a file of the default cord when ``--default``
names one. A model of one cord predicts every cord as its own; a model of several cords
(``cord_inputs``) is told each move's cord. The floors of a model of several cords on the test
cords (``FLOORS``: 0.3 cm one end, 0.5 cm both) are checked on the mean over all test cords.

    python benchmarks/cords_model.py --model FILE [FILE ...] --data data/cords-test-22.npz
        [--default data/transitions-heldout.npz] [--out runs/cords-model]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch

from dlo_env.atomic import file_digest, write_text_atomic
from dlo_env.dataset.transitions import (
    GRASP_NAMES,
    PARAM_COLUMNS,
    TransitionDataset,
    load_transitions,
)
from dlo_env.randomize import TEST_CORDS
from dlo_env.shapes import error
from latent_model.transition_metrics import cords_of
from latent_model.transition_model import TransitionModel

#: Mean one-move error floors on the test cords, metres: one end, both ends.
FLOORS = {"one end": 0.003, "both": 0.005}
#: Share within this of the observed shape, metres.
WITHIN = 0.01


def errors(model: TransitionModel, data: TransitionDataset) -> np.ndarray:
    """The one-move error of every transition of ``data``, metres."""
    out = np.zeros(len(data.grasp))
    for code, name in enumerate(GRASP_NAMES):
        idx = np.flatnonzero(data.grasp == code)
        if len(idx):
            pred = model.predict(data.start[idx], name, data.end_displacement(idx),
                                 params=cords_of(model, data, idx))
            out[idx] = error(pred, data.next[idx])
    return out


def cord_index(data: TransitionDataset) -> np.ndarray:
    """For each transition, the index of the test cord it was collected on (-1: none)."""
    rows = np.asarray(data.params, dtype=np.float64)
    out = np.full(len(rows), -1)
    for i, cord in enumerate(TEST_CORDS):
        test = np.array([cord[k] for k in PARAM_COLUMNS])
        out[np.isclose(rows, test, rtol=1e-6).all(axis=1)] = i
    return out


def summary(e: np.ndarray, grasp: np.ndarray) -> dict[str, dict[str, float]]:
    """Mean (metres), share within ``WITHIN`` and count, for moves of one end and of both."""
    out = {}
    for group, sel in (("one end", grasp < 2), ("both", grasp == 2)):
        if sel.any():
            out[group] = {"mean": float(e[sel].mean()), "within_1cm": float(np.mean(
                e[sel] <= WITHIN)), "moves": int(sel.sum())}
    return out


def report(model: TransitionModel, data: TransitionDataset, default: TransitionDataset | None
           ) -> dict[str, object]:
    """Per test cord, over all test cords, and on the default cord: ``summary`` rows."""
    e = errors(model, data)
    cords = cord_index(data)
    rows: dict[str, object] = {}
    for i in range(len(TEST_CORDS)):
        sel = cords == i
        if sel.any():
            rows[f"cord {i}"] = summary(e[sel], data.grasp[sel])
    on_test = cords >= 0
    rows["test cords"] = summary(e[on_test], data.grasp[on_test])
    if default is not None:
        rows["default cord"] = summary(errors(model, default), default.grasp)
    return rows


def _cell(row: dict[str, dict[str, float]], group: str) -> str:
    if group not in row:
        return "-"
    r = row[group]
    return f"{100 * r['mean']:.2f} ({100 * r['within_1cm']:.0f} %)"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", nargs="+", default=[""],
                        help="transition models, files or folders ('' or none: the shipped "
                             "one-cord model)")
    parser.add_argument("--data", required=True,
                        help="moves of the test cords (dlo collect --kind transitions "
                             "--test-cords)")
    parser.add_argument("--default", default=None,
                        help="moves of the default cord (dlo collect --kind transitions)")
    parser.add_argument("--out", default="runs/cords-model", help="results folder")
    args = parser.parse_args()
    torch.set_num_threads(1)
    data = load_transitions(args.data)
    if not (cord_index(data) >= 0).any():
        raise SystemExit(f"--data must hold moves of the test cords (dlo collect --kind "
                         f"transitions --test-cords), got none in {args.data}")
    default = load_transitions(args.default) if args.default else None
    results = []
    for path in args.model:
        model = TransitionModel.load_or_pretrained(path or None, device="cpu")
        rows = report(model, data, default)
        name = path or "shipped one-cord model"
        results.append({"model": name, "digest": file_digest(
            Path(path) / "transition.pt" if path and Path(path).is_dir() else path)
            if path else "", "cord_inputs": model.config.cord_inputs, "rows": rows})
        print(f"\n{name} (cord_inputs={model.config.cord_inputs}): mean one-move error, cm "
              f"(share within 1 cm)")
        print("| cords | one end | both |\n|---|---|---|")
        for key, row in rows.items():
            print(f"| {key} | {_cell(row, 'one end')} | {_cell(row, 'both')} |")
        test = rows["test cords"]
        checks = [f"{g} {100 * test[g]['mean']:.2f} cm "
                  f"{'<=' if test[g]['mean'] <= f else '>'} {100 * f:g} cm"
                  for g, f in FLOORS.items() if g in test]
        print("floors on the test cords: " + "; ".join(checks))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out / "cords_model.json", json.dumps(
        {"data": args.data, "data_digest": file_digest(args.data), "default": args.default,
         "models": results}, indent=1))
    print(f"wrote {out / 'cords_model.json'}")


if __name__ == "__main__":
    main()
