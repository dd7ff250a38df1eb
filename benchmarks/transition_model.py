"""The transition model against the simulator: every floor of the model, measured in one run.

1. held-out one-move error by grasp (and two-, three-move chains), from a transition file
   collected with another seed than the training data; next to it, how far the simulator
   itself lands from the held-out shape when it replays a move from the stored start and
   from a start whose links are turned by a fraction of a degree (is the error the physics'
   own, or the model's?), and a figure of the worst both-ends moves;
2. the moves of the linear-3 test tasks chained from the start (three predictions in a row)
   against the task goals, next to the simulator itself replaying them rest to rest;
3. transitions from analytic shapes the data never holds as such (arcs, S-curves, spirals,
   zigzags): each settled in the simulator, then one random move of 1-35 cm (with both ends
   held, only shapes whose ends are within the grippers' span, as every dual-arm start), by
   family and by grasp;
4. throughput: for each grasp, one batch of 1024 predictions against simulating the same 1024
   moves, as a ratio per transition (torch on 1 thread and on all threads; the simulator in
   one process; the floor holds for every grasp), and the trade-off of every way to predict
   (the mean network, the first k networks of the ensemble for every k): speed on 1 thread
   and held-out one-move error;
5. predictions off the table where the simulator stays on it.

    python benchmarks/transition_model.py [--model PATH] [--heldout data/transitions-heldout.npz]
        [--curves 400] [--seed 7] [--replays 250] [--out runs/transition-benchmark]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch

from dlo_bench.report import json_ready
from dlo_env.cord import Cord, CordParams
from dlo_env.core.atomic import atomic_path, write_text_atomic
from dlo_env.dataset.transitions import GRASP_NAMES, carry_out, load_transitions
from dlo_env.shapes import ANALYTIC_KINDS, analytic_shape, error, on_table
from dlo_env.tasks import (
    DEFAULT_MAX_STEP,
    GRASP_ENDS,
    SPAN_MARGIN,
    load_suite,
)
from latent_model.transition_metrics import FLOORS, report_lines, transition_report
from latent_model.transition_model import TransitionModel

#: With both ends held the grippers stay this close (``max_span * length - SPAN_MARGIN``).
SPAN = CordParams().max_span * CordParams().length - SPAN_MARGIN


def simulate(start: np.ndarray, end: str, move: np.ndarray) -> np.ndarray:
    """The simulator's transition: reset at ``start``, one straight move, wait for rest."""
    cord = Cord(grasp=end)
    cord.reset(start)
    return carry_out(cord, move, DEFAULT_MAX_STEP)[0]


def settled(shape: np.ndarray, end: str) -> np.ndarray:
    """``shape`` after it came to rest in the simulator with ``end`` held."""
    cord = Cord(grasp=end)
    cord.reset(shape)
    cord.settle(tolerance=1e-3, max_time=3.0)
    return cord.shape


def random_move(rng: np.random.Generator, end: str) -> np.ndarray:
    """Uniform direction, length U(1, 35) cm, per held end."""
    parts = []
    for _ in GRASP_ENDS[end]:
        angle, length = rng.uniform(-np.pi, np.pi), rng.uniform(0.01, 0.35)
        parts.append(length * np.array([np.cos(angle), np.sin(angle)]))
    return np.concatenate(parts).astype(np.float32)


def chained_tasks(model: TransitionModel) -> dict[str, float]:
    """Linear-3 test tasks: three predictions in a row vs the goals; the simulator rest to rest."""
    tasks = load_suite("linear-3", "test")
    predicted, replayed = [], []
    for task in tasks:
        shape = task.start
        sim = task.start
        for move in task.moves:
            shape = model.predict(shape, task.grasp, move)
            sim = simulate(sim, task.grasp, move)
        predicted.append(error(shape, task.goal))
        replayed.append(error(sim, task.goal))
    return {"tasks": len(tasks), "model_mean_cm": 100 * float(np.mean(predicted)),
            "model_max_cm": 100 * float(np.max(predicted)),
            "simulator_rest_to_rest_mean_cm": 100 * float(np.mean(replayed))}


def _summary(errors: np.ndarray, ends: np.ndarray) -> dict[str, float | None]:
    # Count, mean, 99th percentile and share within 1 cm; the mean per grasp (None: no case).
    return {"count": len(errors), "mean_cm": 100 * float(errors.mean()),
            "p99_cm": 100 * float(np.percentile(errors, 99)),
            "within_1cm": float((errors <= 0.01).mean()),
            **{f"{end}_mean_cm": (100 * float(errors[ends == end].mean())
                                  if (ends == end).any() else None) for end in GRASP_NAMES}}


def analytic_curves(model: TransitionModel, count: int, seed: int
                    ) -> tuple[dict[str, dict[str, float | None]], dict[str, int]]:
    """Errors of one move from settled analytic shapes, by family and over all (each also by
    grasp); off-table counts."""
    rng = np.random.default_rng(seed)
    out: dict[str, dict[str, float | None]] = {}
    off = {"predicted_off_table": 0, "simulated_off_table": 0, "cases": 0}
    every, every_end = [], []
    for kind in ANALYTIC_KINDS:
        errors, ends = [], []
        for i in range(count // len(ANALYTIC_KINDS)):
            end = GRASP_NAMES[i % 3]
            shape = analytic_shape(kind, rng)
            while end == "both" and np.linalg.norm(shape[-1] - shape[0]) >= SPAN:
                shape = analytic_shape(kind, rng)  # as every dual-arm start: ends within reach
            start = settled(shape, end)
            move = random_move(rng, end)
            truth = simulate(start, end, move)
            pred = model.predict(start, end, move)
            errors.append(error(pred, truth))
            ends.append(end)
            off["cases"] += 1
            off["predicted_off_table"] += int(not on_table(pred) and on_table(truth))
            off["simulated_off_table"] += int(not on_table(truth))
        every.append(np.array(errors))
        every_end.append(np.array(ends))
        out[kind] = _summary(every[-1], every_end[-1])
    out["all"] = _summary(np.concatenate(every), np.concatenate(every_end))
    return out, off


def _seconds(model: TransitionModel, starts: np.ndarray, end: str, moves: np.ndarray,
             repeats: int, members: int | None = None) -> float:
    # Median over ``repeats`` calls of one batch's prediction, per transition.
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        model.predict(starts, end, moves, members=members)
        times.append(time.perf_counter() - t)
    return float(np.median(times)) / len(starts)


def throughput(model: TransitionModel, heldout, batch: int = 1024, repeats: int = 25
               ) -> dict[str, Any]:
    """Seconds per transition for each grasp: the model on a batch of ``batch`` held-out moves
    of that grasp (median of ``repeats`` calls after a warm-up) on 1 thread and on all threads,
    and the simulator on the same moves; with head moves also every way to predict
    (``predictors``) on 1 thread."""
    result: dict[str, Any] = {"batch": batch}
    default_threads = torch.get_num_threads()
    for code, end in enumerate(GRASP_NAMES):
        idx = np.flatnonzero(heldout.grasp == code)
        if not len(idx):
            raise ValueError(f"the held-out file has no {end} moves to time")
        idx = np.resize(idx, batch)
        starts, moves = heldout.start[idx], heldout.end_displacement(idx)

        row: dict[str, float] = {}
        try:
            for threads in sorted({1, default_threads}):
                torch.set_num_threads(threads)
                model.predict(starts, end, moves)
                row[f"model_threads_{threads}_s"] = _seconds(model, starts, end, moves, repeats)
            torch.set_num_threads(1)
            if end == "head":  # the first k networks of the ensemble alone
                for members in predictors(model).values():
                    if members is not None:  # None: the default, timed above
                        row[f"members_{members}_threads_1_s"] = _seconds(
                            model, starts, end, moves, repeats, members)
        finally:
            torch.set_num_threads(default_threads)
        t = time.perf_counter()
        for start, move in zip(starts, moves):
            simulate(start, end, move)
        row["simulator_s"] = (time.perf_counter() - t) / batch
        result[end] = row
    return result


def turned_links(shape: np.ndarray, rng: np.random.Generator, angle: float) -> np.ndarray:
    """``shape`` with every link's heading turned by N(0, ``angle``) radians (lengths kept,
    the head fixed): a start the eye could not tell apart from ``shape``."""
    seg = np.diff(shape.astype(np.float64), axis=0)
    heading = np.arctan2(seg[:, 1], seg[:, 0]) + rng.normal(0.0, angle, len(seg))
    steps = np.linalg.norm(seg, axis=1)[:, None] * np.stack([np.cos(heading), np.sin(heading)], 1)
    points = shape[0] + np.concatenate([np.zeros((1, 2)), np.cumsum(steps, axis=0)])
    return np.clip(points, -0.999, 0.999).astype(np.float32)


def predictability(model: TransitionModel, heldout, count: int, seed: int, angle: float = 0.005
                   ) -> dict[str, dict[str, float]]:
    """Is the model's error the physics' own spread? Per grasp, on ``count`` held-out moves:
    the model's one-move error, the simulator replaying the move from the stored start, and
    the simulator from that start with every link turned by N(0, ``angle``) rad."""
    rng = np.random.default_rng(seed)
    out: dict[str, dict[str, float]] = {}
    for code, name in enumerate(GRASP_NAMES):
        idx = rng.choice(np.flatnonzero(heldout.grasp == code), count, replace=False)
        moves = heldout.end_displacement(idx)
        truth = heldout.next[idx]
        pred = model.predict(heldout.start[idx], name, moves)
        replay = np.stack([simulate(heldout.start[i], name, m) for i, m in zip(idx, moves)])
        turned = np.stack([simulate(turned_links(heldout.start[i], rng, angle), name, m)
                           for i, m in zip(idx, moves)])
        out[name] = {}
        for label, shapes in (("model", pred), ("replay", replay), ("turned_start", turned)):
            e = error(shapes, truth)
            out[name][f"{label}_mean_cm"] = 100 * float(e.mean())
            out[name][f"{label}_within_1cm"] = float((e <= 0.01).mean())
    return out


def worst_cases_png(model: TransitionModel, heldout, end: str, path: Path, count: int = 6
                    ) -> Path:
    """The start, the simulator's and the model's shape for held-out ``end`` moves at the
    top of the error ranking (the 1st, 2nd, 5th... percentile of the worst), as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    idx = np.flatnonzero(heldout.grasp == GRASP_NAMES.index(end))
    pred = model.predict(heldout.start[idx], end, heldout.end_displacement(idx))
    err = error(pred, heldout.next[idx])
    order = np.argsort(err)[::-1]
    ranks = np.unique(np.round(np.geomspace(1, 0.1 * len(idx), count)).astype(int) - 1)
    fig, axes = plt.subplots(1, len(ranks), figsize=(3.2 * len(ranks), 3.4))
    for ax, rank in zip(np.atleast_1d(axes), ranks):
        k = order[rank]
        i = idx[k]
        ax.plot(*heldout.start[i].T, "-", color="0.65", lw=1.5, label="start")
        ax.plot(*heldout.next[i].T, "-o", ms=2, color="C0", label="simulator")
        ax.plot(*pred[k].T, "-o", ms=2, color="C3", label="model")
        for row, point in ((0, 0), (1, -1)):
            if np.abs(heldout.moved[i, row]).sum():
                ax.annotate("", xy=heldout.start[i, point] + heldout.moved[i, row],
                            xytext=heldout.start[i, point],
                            arrowprops={"arrowstyle": "->", "color": "k"})
        ax.set_title(f"#{rank + 1} worst of {len(idx)}: {100 * err[k]:.1f} cm", fontsize=9)
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
    np.atleast_1d(axes)[0].legend(fontsize=7, loc="best")
    label = "both-ends" if end == "both" else f"{end}-end"
    fig.suptitle(f"held-out {label} moves the model gets most wrong (arrows: the held ends' moves)",
                 fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=80, format="png")
    plt.close(fig)
    return path


def predictors(model: TransitionModel) -> dict[str, int | None]:
    """The ways to predict that section 4 compares, as ``members`` of ``predict``: the mean
    network when the model has one (None, the default and the floors' model), and the first
    k networks of the ensemble for every k (the whole ensemble is the default without one)."""
    e = model.config.members
    ways: dict[str, int | None] = {"mean network": None} if model.mean_net is not None else {}
    for k in range(1, e + 1):
        ways[f"{k} of {e}"] = None if k == e and model.mean_net is None else k
    return ways


def predictor_accuracy(model: TransitionModel, heldout) -> dict[str, dict[str, float]]:
    """Held-out one-move mean error (cm) by grasp of every way to predict (``predictors``)."""
    out: dict[str, dict[str, float]] = {}
    for label, members in predictors(model).items():
        out[label] = {}
        for code, name in enumerate(GRASP_NAMES):
            idx = np.flatnonzero(heldout.grasp == code)
            pred = model.predict(heldout.start[idx], name, heldout.end_displacement(idx),
                                 members=members)
            out[label][name] = 100 * float(error(pred, heldout.next[idx]).mean())
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default=None, help="transition model (default: shipped)")
    parser.add_argument("--heldout", default="data/transitions-heldout.npz",
                        help="held-out transitions (dlo collect transitions --seed 1)")
    parser.add_argument("--curves", type=int, default=400, help="analytic-shape transitions")
    parser.add_argument("--seed", type=int, default=7,
                        help="seed of the analytic shapes and of the replayed moves")
    parser.add_argument("--replays", type=int, default=250,
                        help="held-out moves per grasp replayed in the simulator")
    parser.add_argument("--out", default="runs/transition-benchmark", help="results folder")
    args = parser.parse_args()
    model = TransitionModel.load_or_pretrained(args.model, device="cpu")
    heldout = load_transitions(args.heldout)
    print(f"load average at start: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    print(f"model: {model.config}")

    rows, rank = transition_report(model, heldout)
    print(f"\n1. held-out transitions ({args.heldout}, {len(heldout)} moves)")
    for line in report_lines(rows, rank):
        print("   " + line)
    one = {r.group: r for r in rows if r.moves == 1}
    checks = []
    for g in ("head", "tail"):
        checks.append((f"{g} mean <= {FLOORS['single_mean_cm']} cm", one[g].mean_cm,
                       one[g].mean_cm <= FLOORS["single_mean_cm"]))
        checks.append((f"{g} within 1 cm >= {FLOORS['single_within']:.1%}", one[g].within_1cm,
                       one[g].within_1cm >= FLOORS["single_within"]))
    checks.append((f"both mean <= {FLOORS['both_mean_cm']} cm", one["both"].mean_cm,
                   one["both"].mean_cm <= FLOORS["both_mean_cm"]))
    checks.append((f"both within 1 cm >= {FLOORS['both_within']:.0%}", one["both"].within_1cm,
                   one["both"].within_1cm >= FLOORS["both_within"]))

    spread = predictability(model, heldout, args.replays, args.seed)
    print(f"\n   is the error the physics' own? {args.replays} held-out moves per grasp, mean "
          "(within 1 cm):")
    for name, r in spread.items():
        print(f"   {name:<5} model {r['model_mean_cm']:.3f} cm ({r['model_within_1cm']:.1%}); "
              f"simulator from the stored start {r['replay_mean_cm']:.3f} cm "
              f"({r['replay_within_1cm']:.1%}); from the start with links turned by 0.005 rad "
              f"{r['turned_start_mean_cm']:.3f} cm ({r['turned_start_within_1cm']:.1%})")
    worst = worst_cases_png(model, heldout, "both", Path(args.out) / "worst-both.png")
    print(f"   the worst both-ends moves: {worst}")

    chain = chained_tasks(model)
    print(f"\n2. linear-3 test tasks, moves chained from the start ({chain['tasks']} tasks)")
    print(f"   model:     {chain['model_mean_cm']:.3f} cm mean to the goal "
          f"(worst {chain['model_max_cm']:.2f} cm)")
    print(f"   simulator: {chain['simulator_rest_to_rest_mean_cm']:.3f} cm mean (rest to rest)")
    checks.append((f"chained linear-3 mean <= {FLOORS['chain_cm']} cm", chain["model_mean_cm"],
                   chain["model_mean_cm"] <= FLOORS["chain_cm"]))

    curves, off = analytic_curves(model, args.curves, args.seed)
    print(f"\n3. one move from settled analytic shapes (seed {args.seed})")
    for kind, r in curves.items():
        grasps = " / ".join("-" if r[f"{end}_mean_cm"] is None else f"{r[f'{end}_mean_cm']:.2f}"
                            for end in GRASP_NAMES)
        print(f"   {kind:<8} {r['count']:>4}  mean {r['mean_cm']:.3f} cm  p99 {r['p99_cm']:.2f} cm"
              f"  within 1 cm {r['within_1cm']:.1%}  ({grasps} cm {' / '.join(GRASP_NAMES)})")
    checks.append((f"analytic shapes mean <= {FLOORS['curves_cm']} cm", curves["all"]["mean_cm"],
                   curves["all"]["mean_cm"] <= FLOORS["curves_cm"]))

    speed = throughput(model, heldout)
    print(f"\n4. throughput, batches of {speed['batch']} held-out moves per grasp")
    for end in GRASP_NAMES:
        row = speed[end]
        sim = row["simulator_s"]
        models = ", ".join(f"{1e6 * v:.1f} us on {k.split('_')[2]} thread(s): {sim / v:.0f}x"
                           for k, v in row.items() if k.startswith("model_threads"))
        print(f"   {end:<5} simulator (one process) {1e3 * sim:.2f} ms per transition; "
              f"model {models}")
    accuracy = predictor_accuracy(model, heldout)
    print("   ways to predict (head moves, 1 thread; held-out one-move mean by grasp; the first "
          "is the default):")
    print(f"   {'networks':<12} {'us/transition':>13} {'speed-up':>8} {'head':>7} {'tail':>7} "
          f"{'both':>7}")
    head = speed["head"]
    for (label, members), errors in zip(predictors(model).items(), accuracy.values()):
        value = head["model_threads_1_s" if members is None
                     else f"members_{members}_threads_1_s"]
        print(f"   {label:<12} {1e6 * value:>13.1f} {head['simulator_s'] / value:>7.0f}x "
              + " ".join(f"{errors[g]:>5.3f}cm" for g in GRASP_NAMES))

    def speedup(threads: str) -> dict[str, float]:  # per grasp: all threads or one
        return {end: speed[end]["simulator_s"] / min(
            v for k, v in speed[end].items() if k.startswith(f"model_threads_{threads}"))
            for end in GRASP_NAMES}

    best, one_thread = speedup(""), speedup("1_")
    checks.append((f"speed-up >= {FLOORS['speedup']:.0f}x, every grasp (all threads)",
                   min(best.values()), min(best.values()) >= FLOORS["speedup"]))

    print(f"\n5. off the table: {off['predicted_off_table']} predictions of {off['cases']} "
          f"analytic-shape moves where the simulator stayed on it "
          f"(simulator itself off: {off['simulated_off_table']})")
    checks.append(("predictions off the table where the cord is not == 0",
                   off["predicted_off_table"], off["predicted_off_table"] == 0))

    print("\nfloors")
    for name, value, ok in checks:
        shown = f"{value:.4f}" if isinstance(value, float) else str(value)
        print(f"   {name:<48} {shown:>10}  {'PASS' if ok else 'FAIL'}")
    print("   (95 % intervals over episodes of the held-out file: mean "
          + ", ".join(f"{g} {one[g].mean_low_cm:.3f}-{one[g].mean_high_cm:.3f} cm"
                      for g in GRASP_NAMES)
          + "; within 1 cm "
          + ", ".join(f"{g} {one[g].within_low:.2%}-{one[g].within_high:.2%}"
                      for g in GRASP_NAMES) + ")")
    out = Path(args.out)
    write_text_atomic(out / "transition-benchmark.json", json.dumps(json_ready({
        "heldout": [r.__dict__ for r in rows], "spread_rank": rank, "chained_linear3": chain,
        "analytic": curves, "off_table": off, "throughput": speed,
        "predictors_one_move_cm": accuracy, "predictability": spread,
        "speedup_one_thread": one_thread, "speedup_best": best,
        "floors": [{"name": n, "value": v, "pass": p} for n, v, p in checks]}), indent=1))
    print(f"\nwrote {out / 'transition-benchmark.json'}")


if __name__ == "__main__":
    main()
