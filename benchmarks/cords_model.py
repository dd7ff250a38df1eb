"""A transition model on cords that differ: its one-move error on each held-out test cord.

For each model given, the mean one-move error (cm) and the share within 1 cm of moves of one
end (head and tail) and of both ends, on every cord of a file collected with ``dlo collect
transitions --test-cords`` (the six ``dlo_env.randomize.TEST_CORDS``, which no
cord-conditioned model trains near), and on a file of the default cord when ``--default``
names one. A model of one cord predicts every cord as its own; a model of several cords
(``cord_inputs``) is told each move's cord. The floors of a model of several cords on the test
cords (``FLOORS``: 0.3 cm one end, 0.5 cm both) are checked on the mean over all test cords.
``--other`` adds a file of moves of other cords, each cord reported on its own row (for
example the letters' cord, ``dlo_env.designed_suites.LETTERS_CORD``, collected with ``dlo
collect transitions --randomize bending_stiffness=0.003:0.003 friction=0.6:0.6
mass=0.3:0.3``).

    python benchmarks/cords_model.py --model FILE [FILE ...] --data data/cords-test-22.npz
        [--default data/transitions-heldout.npz] [--other FILE] [--out runs/cords-model]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch

from dlo_env.core.atomic import file_digest, write_text_atomic
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
#: The model must predict at least this many times faster than the simulator.
SPEED_FLOOR = 1000.0


def speed(model: TransitionModel, data: TransitionDataset, batch: int, repeats: int
          ) -> dict[str, dict[str, float]]:
    """Per grasp: seconds per transition of the model (a batch of ``batch`` moves, median of
    ``repeats`` calls after one warm-up) and of the simulator (the same moves, each on its
    own cord), and their ratio."""
    import time

    from dlo_env.cord import Cord, CordParams
    from dlo_env.dataset.transitions import carry_out
    from dlo_env.tasks import DEFAULT_MAX_STEP

    out = {}
    for code, name in enumerate(GRASP_NAMES):
        idx = np.resize(np.flatnonzero(data.grasp == code), batch)
        starts, moves = data.start[idx], data.end_displacement(idx)
        params = cords_of(model, data, idx)
        model.predict(starts, name, moves, params=params)
        times = []
        for _ in range(repeats):
            t = time.perf_counter()
            model.predict(starts, name, moves, params=params)
            times.append(time.perf_counter() - t)
        t = time.perf_counter()
        for i, start, move in zip(idx, starts, moves):
            row = dict(zip(PARAM_COLUMNS, map(float, data.params[i])))
            cord = Cord(CordParams(**row), grasp=name)
            cord.reset(start)
            carry_out(cord, move, DEFAULT_MAX_STEP)
        simulator = (time.perf_counter() - t) / batch
        predicted = float(np.median(times)) / batch
        out[name] = {"model_s": predicted, "simulator_s": simulator,
                     "ratio": simulator / predicted}
    return out


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


def report(model: TransitionModel, data: TransitionDataset, default: TransitionDataset | None,
           other: TransitionDataset | None = None) -> dict[str, object]:
    """Per test cord, over all test cords, on the default cord and on each cord of ``other``:
    ``summary`` rows."""
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
    if other is not None:
        e = errors(model, other)
        cords, which = np.unique(np.asarray(other.params, dtype=np.float64), axis=0,
                                 return_inverse=True)
        for i, cord in enumerate(cords):
            sel = which.reshape(-1) == i
            label = ", ".join(f"{k} {v:g}" for k, v in zip(PARAM_COLUMNS, cord))
            rows[f"cord ({label})"] = summary(e[sel], other.grasp[sel])
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
                        help="moves of the test cords (dlo collect transitions "
                             "--test-cords)")
    parser.add_argument("--default", default=None,
                        help="moves of the default cord (dlo collect transitions)")
    parser.add_argument("--other", default=None,
                        help="moves of other cords, each reported on its own (dlo collect "
                             "transitions --randomize NAME=V:V ...)")
    parser.add_argument("--speed", type=int, default=0,
                        help="time each model over this many calls (0: no timing)")
    parser.add_argument("--batch", type=int, default=1024, help="moves per timed call")
    parser.add_argument("--threads", type=int, default=1, help="torch threads")
    parser.add_argument("--out", default="runs/cords-model", help="results folder")
    args = parser.parse_args()
    for name in ("speed", "batch", "threads"):
        if getattr(args, name) < (0 if name == "speed" else 1):
            parser.error(f"--{name} must be >= {0 if name == 'speed' else 1}, "
                         f"got {getattr(args, name)}")
    torch.set_num_threads(args.threads)
    data = load_transitions(args.data)
    if not (cord_index(data) >= 0).any():
        raise SystemExit(f"--data must hold moves of the test cords (dlo collect "
                         f"transitions --test-cords), got none in {args.data}")
    default = load_transitions(args.default) if args.default else None
    other = load_transitions(args.other) if args.other else None
    results = []
    for path in args.model:
        model = TransitionModel.load_or_pretrained(path or None, device="cpu")
        rows = report(model, data, default, other)
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
        if args.speed:
            timed = speed(model, data, args.batch, args.speed)
            results[-1]["speed"] = {"batch": args.batch, "threads": args.threads, **timed}
            print(f"speed, batch {args.batch}, {args.threads} torch thread(s): " + "; ".join(
                f"{g} {1e6 * r['model_s']:.1f} us/move against the simulator's "
                f"{1e3 * r['simulator_s']:.1f} ms: {r['ratio']:.0f}x"
                f" {'>=' if r['ratio'] >= SPEED_FLOOR else '<'} {SPEED_FLOOR:.0f}x"
                for g, r in timed.items()))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out / "cords_model.json", json.dumps(
        {"data": args.data, "data_digest": file_digest(args.data), "default": args.default,
         "models": results}, indent=1))
    print(f"wrote {out / 'cords_model.json'}")


if __name__ == "__main__":
    main()
