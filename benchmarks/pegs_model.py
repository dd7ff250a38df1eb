"""A transition model around pegs: its one-move error on moves that touch a peg and on the rest.

For each model given, the mean one-move error (cm) and the share within 1 cm on a held-out
file collected with ``dlo collect transitions --max-pegs N``, split into the moves that
touch a peg (the cord, before or after, within ``TOUCH`` of a peg's surface, or a gripper
stopped by one) and those that touch none, each by one end (head and tail) and both ends. Every
model is told the move's pegs: one with ``peg_reach`` sees them, every model stops the
grippers at them. The floors of issue 36 (``FLOORS``): moves that touch a peg at most 0.5 cm
mean; moves that touch none within 10 % of the first model's error (give the peg-free model
first).

``--replay N`` also measures what limits any model: the simulator itself, N moves of each group
(from a start at rest, ending at rest) replayed from their recorded start and compared with the
recorded shape after. The reset from a stored shape loses what the shape does not hold
(velocities, the contact solver's state, float32 rounding), so a move whose outcome turns on
those (a cord that may slip either way round a peg) differs on replay: a floor for any model of
the stored start.

    python benchmarks/pegs_model.py --model latent_model/pretrained/transition.pt FILE \
        --data data/pegs-heldout-32.npz [--out runs/pegs-model] [--replay 1000]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

import numpy as np
import torch

from dlo_env.cord import PEG_RADIUS, Cord, CordParams, peg_clearance
from dlo_env.core.atomic import file_digest, write_text_atomic
from dlo_env.dataset.transitions import (
    GRASP_NAMES,
    PARAM_COLUMNS,
    TransitionDataset,
    carry_out,
    load_transitions,
)
from dlo_env.shapes import error
from dlo_env.tasks import GOAL_STRETCH
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


def replay_errors(data: TransitionDataset, idx: np.ndarray) -> np.ndarray:
    """``(len(idx),)`` distance between the recorded shape after each move and the simulator's
    when the move is replayed from its recorded start, metres (the cord, pegs, peg radius and
    action size of the collection, read from the file's metadata)."""
    collected = data.metadata.get("collect", {})
    recorded = data.metadata.get("cord") or collected.get("cord")
    if recorded is None or "max_step" not in collected or (
            data.peg_count.any() and "peg_radius" not in collected):
        raise ValueError("replaying needs the collection's cord, max_step and peg_radius in "
                         "the file's metadata (a file written by dlo collect "
                         "transitions)")
    base = CordParams(**recorded)
    radius = float(collected.get("peg_radius", PEG_RADIUS))  # only read where pegs stand
    max_step = float(collected["max_step"])
    out = np.zeros(len(idx))
    for k, i in enumerate(idx):
        # The file keeps the cord's parameters as float32: the collection's own where they match.
        params = dataclasses.replace(base, **{
            c: getattr(base, c) if np.float32(getattr(base, c)) == v else float(v)
            for c, v in zip(PARAM_COLUMNS, data.params[i])})
        cord = Cord(params, grasp=GRASP_NAMES[int(data.grasp[i])], peg_radius=radius)
        pegs = data.peg_list(i)
        if len(pegs):
            cord.set_pegs(pegs)
        cord.reset(data.start[i].astype(np.float64))
        move = data.end_displacement([i])[0]
        out[k] = error(carry_out(cord, move, max_step)[0], data.next[i])
    return out


def replayable(data: TransitionDataset) -> np.ndarray:
    """``(T,)`` moves that can be replayed from their start: the move ended at rest, its start
    is the first of an episode or the end of a move that came to rest, and every segment of the
    start lies within ``GOAL_STRETCH`` of its rest length (a cord held taut round pegs can be
    stretched, a state a reset does not reproduce)."""
    seg = np.linalg.norm(np.diff(data.start, axis=1), axis=-1)
    rest = data.params[:, PARAM_COLUMNS.index("length")] / (data.start.shape[1] - 1)
    unstretched = np.abs(seg / rest[:, None] - 1.0).max(axis=1) <= GOAL_STRETCH
    previous = np.ones(len(data), dtype=bool)  # the move before, in the same episode
    same = (data.episode[1:] == data.episode[:-1]) & (data.step[1:] == data.step[:-1] + 1)
    previous[1:] = np.where(same, data.at_rest[:-1], data.step[1:] == 0)
    previous[0] = data.step[0] == 0
    return data.at_rest & previous & unstretched


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", nargs="+", required=True, help="transition model files")
    parser.add_argument("--data", required=True, help="held-out transitions around pegs")
    parser.add_argument("--out", default="runs/pegs-model", help="folder of results.json")
    parser.add_argument("--threads", type=int, default=1, help="torch threads")
    parser.add_argument("--replay", type=int, default=0, metavar="N",
                        help="also replay N moves of each group in the simulator from their "
                        "recorded start (what limits any model; default 0: none)")
    parser.add_argument("--seed", type=int, default=0, help="which moves --replay draws")
    args = parser.parse_args(argv)
    if args.replay < 0:
        parser.error(f"--replay must be >= 0, got {args.replay}")
    torch.set_num_threads(args.threads)
    data = load_transitions(args.data)
    if not data.peg_count.any():
        parser.error("--data holds no move around a peg: collect it with --max-pegs N")
    touch = touching(data)
    one = data.grasp < 2
    groups = {"touching": touch, "untouched": ~touch}
    print(f"{args.data}: {len(data)} moves, {int(touch.sum())} touch a peg "
          f"({int((data.peg_count > 0).sum())} with pegs on the table)")
    w = max(16, *(len(str(m)) for m in args.model))  # the model column's width
    header = f"{'model':>{w}}  {'moves':>10}  {'one end cm':>10}  {'both cm':>8}  " \
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
            print(f"{str(path):>{w}}  {label:>10}  {r['one_end_cm'] or 0:10.3f}  "
                  f"{r['both_cm'] or 0:8.3f}  {r['mean_cm']:7.3f}  {r['within_1cm']:11.1%}")
        results[path] = {"digest": file_digest(path)[:16], "peg_reach": model.config.peg_reach,
                         **row}
    first = next(iter(results.values()))
    for path, row in list(results.items())[1:]:
        rise = row["untouched"]["mean_cm"] / first["untouched"]["mean_cm"] - 1
        ok_touch = row["touching"]["mean_cm"] <= 100 * FLOORS["touching"]
        ok_rise = rise <= FLOORS["untouched_rise"]
        print(f"{path}: touching {row['touching']['mean_cm']:.3f} cm (floor "
              f"{100 * FLOORS['touching']:.1f}: {'met' if ok_touch else 'NOT met'}); untouched "
              f"{rise:+.1%} against {args.model[0]} (floor +"
              f"{FLOORS['untouched_rise']:.0%}: {'met' if ok_rise else 'NOT met'})")
    replays: dict[str, dict] = {}
    if args.replay:
        rng = np.random.default_rng(args.seed)
        can = replayable(data)
        print(f"the simulator replaying up to {args.replay} moves of each group from their "
              f"recorded start ({int((~can).sum())} moves left out: not at rest after, or a "
              "start not at rest or stretched); distance to the recorded shape after:")
        for label, sel in groups.items():
            pool = np.flatnonzero(sel & can)
            if not len(pool):
                continue
            idx = np.sort(rng.choice(pool, min(args.replay, len(pool)), replace=False))
            e = replay_errors(data, idx)
            ends = data.grasp[idx] < 2
            replays[label] = {
                "count": len(idx), "mean_cm": 100 * float(e.mean()),
                "one_end_cm": 100 * float(e[ends].mean()) if ends.any() else None,
                "both_cm": 100 * float(e[~ends].mean()) if (~ends).any() else None,
                "median_cm": 100 * float(np.median(e)), "over_1cm": float((e > WITHIN).mean())}
            r = replays[label]
            print(f"{'simulator replay':>{w}}  {label:>10}  {r['one_end_cm'] or 0:10.3f}  "
                  f"{r['both_cm'] or 0:8.3f}  {r['mean_cm']:7.3f}  {1 - r['over_1cm']:11.1%}  "
                  f"({len(idx)} moves, median {r['median_cm']:.3f} cm)")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out / "results.json", json.dumps(
        {"data": args.data, "touch_m": TOUCH, "models": results, "replay": replays},
        indent=2) + "\n")
    print(f"wrote {out / 'results.json'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
