"""How the transition model's misses fall with its training data: a measured learning curve.

For each size N, one network of the shipped architecture (``members=1``, contact vectors) is
trained on the first episodes of one transition file, about N transitions, with the same steps,
seed and settings, and scored on a validation file none of them trained on and on up to
``--fit-sample`` of its own training moves (not of the 5 % of episodes its training holds
back): per grasp, the one-move mean error and the share of
moves within 1 cm. A power law fitted to the misses (``1 - share``) on unseen moves against N
(least squares in log-log) says how many transitions one network of this architecture would
need to reach each within-1 cm floor if the trend went on, and where on the curve a reference
model (the shipped one by default) stands; the figure shows the curve.

Each size's training is kept under ``--runs`` and resumes from its last checkpoint (a quarter
of its steps) after a kill; runs of several invocations (say, two at once with different
``--sizes``) are fitted together. The curve (JSON and PNG) goes to ``--out`` (default
``--runs``); the committed one in ``benchmarks/transition_scaling/`` is refreshed with ``--out
benchmarks/transition_scaling``::

    python benchmarks/transition_scaling.py --data data/transitions-scale-20.npz \\
        --validation data/transitions-val-4.npz \\
        [--sizes 6250 12500 25000 50000 100000 200000] [--steps 100000] [--width 256] \\
        [--threads 1] [--reference-size 840000] [--architecture chain] [--cord-inputs]
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np
import torch

from dlo_bench.charts import plot_scaling
from dlo_env.core.atomic import file_digest, write_text_atomic
from dlo_env.dataset.transitions import (
    GRASP_NAMES,
    TransitionDataset,
    load_transitions,
    split_transitions,
)
from latent_model.transition_metrics import FLOORS, WITHIN, rollout_errors
from latent_model.transition_model import TransitionModel, TransitionModelConfig
from latent_model.transition_training import (
    CHECKPOINT_FILE,
    TransitionTrainConfig,
    train_transition_model,
)

#: The within-1 cm floors by grasp.
WITHIN_FLOORS = {"head": FLOORS["single_within"], "tail": FLOORS["single_within"],
                 "both": FLOORS["both_within"]}


def first_episodes(data: TransitionDataset, size: int) -> TransitionDataset:
    """The transitions of the fewest first episodes (by id) that hold at least ``size``."""
    ids, counts = np.unique(data.episode, return_counts=True)
    if size > counts.sum():
        raise ValueError(f"--sizes: {size} is more than the file's {counts.sum()} transitions")
    last = ids[np.searchsorted(np.cumsum(counts), size)]
    return data.subset(data.episode <= last)


def trained_sample(subset: TransitionDataset, tc: TransitionTrainConfig, count: int
                   ) -> TransitionDataset:
    """Up to ``count`` transitions the network trained on: the training side of the split
    ``train_transition_model`` makes, not the episodes it holds back for validation."""
    train, _ = split_transitions(subset, tc.validation_fraction, seed=tc.seed)
    pick = np.random.default_rng(tc.seed).choice(len(train), min(count, len(train)),
                                                 replace=False)
    return train.subset(np.sort(pick))


def scores(model: TransitionModel, data: TransitionDataset) -> dict[str, dict[str, float]]:
    """Per grasp: moves, mean error (cm) and share within 1 cm of one-move predictions."""
    first, e = rollout_errors(model, data, 1)
    out = {}
    for code, end in enumerate(GRASP_NAMES):
        mine = e[data.grasp[first] == code]
        out[end] = {"moves": int(len(mine)),
                    "mean_cm": float(100 * mine.mean()) if len(mine) else None,
                    "within": float((mine <= WITHIN).mean()) if len(mine) else None}
    return out


def misses(rows: list[dict], group: str, moves: str = "unseen") -> np.ndarray:
    """Each row's share of ``group``'s moves off by more than 1 cm (nan where it had none)."""
    within = [r[moves][group]["within"] for r in rows]
    return np.array([np.nan if w is None else 1 - w for w in within], dtype=np.float64)


def power_law(sizes: np.ndarray, misses: np.ndarray) -> tuple[float, float] | None:
    """``(a, b)`` with ``misses ~ exp(a) * sizes ** b``, or None without two usable points
    (a share that is 0 or unknown has no logarithm)."""
    keep = np.isfinite(misses) & (misses > 0)
    if keep.sum() < 2:
        return None
    b, a = np.polyfit(np.log(sizes[keep]), np.log(misses[keep]), 1)
    return float(a), float(b)


def size_for(fit: tuple[float, float] | None, share: float) -> float:
    """Transitions at which the fitted misses fall to ``share`` (inf if they do not fall)."""
    if fit is None or fit[1] >= 0 or not share > 0:
        return math.inf
    a, b = fit
    log_size = (math.log(share) - a) / b
    return math.exp(log_size) if log_size < 700 else math.inf


def needed(fit: tuple[float, float] | None, floor: float) -> float:
    """Transitions at which the fitted misses reach ``1 - floor`` (inf if they do not fall)."""
    return size_for(fit, 1 - floor)


def transitions(n: float) -> str:
    """``n`` transitions as printed: a count, or that the fit never gets there."""
    return f"about {n:,.0f} transitions of this kind" if math.isfinite(n) else "never (no fall)"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True, help="one transition file (dlo collect)")
    parser.add_argument("--validation", default="data/transitions-val-4.npz",
                        help="transitions none of the runs trained on (a selection file, not "
                             "the held-out file of the floors)")
    parser.add_argument("--sizes", type=int, nargs="+",
                        default=[6_250, 12_500, 25_000, 50_000, 100_000, 200_000])
    parser.add_argument("--steps", type=int, default=100_000)
    parser.add_argument("--fit-sample", type=int, default=6000,
                        help="training moves scored per size (the fit, against unseen moves)")
    parser.add_argument("--width", type=int, default=TransitionModelConfig.width,
                        help="hidden units per layer (the shipped networks': the default)")
    parser.add_argument("--architecture", choices=("mlp", "chain"), default="mlp",
                        help="the network: an MLP on the whole chain, or the chain-local "
                             "network (latent_model.chain_network)")
    parser.add_argument("--depth", type=int, default=None,
                        help="the MLP's hidden layers or the chain network's residual blocks "
                             "(None: 3 for the MLP, 7 for the chain network: a 20-point cord)")
    parser.add_argument("--reference", default=None,
                        help="a transition model file scored beside the curve (default: the "
                             "shipped model), placed on it as the training size of one network "
                             "that misses as often")
    parser.add_argument("--reference-size", type=float, default=None,
                        help="transitions the reference model was trained on: it is drawn "
                             "there (the shipped model: 840000, of several kinds)")
    parser.add_argument("--cord-inputs", action="store_true",
                        help="networks that see each move's cord, for --data of several cords "
                             "(dlo collect transitions --randomize); --validation may then be "
                             "moves of the held-out test cords (dlo collect transitions "
                             "--test-cords)")
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--runs", default="runs/transition-scaling",
                        help="folder of the trainings, one per size (resumed)")
    parser.add_argument("--out", default=None,
                        help="folder of the curve's JSON and PNG (default: --runs)")
    args = parser.parse_args()
    for name in ("steps", "fit_sample", "width", "threads"):
        if getattr(args, name) < 1:
            parser.error(f"--{name.replace('_', '-')} must be >= 1, got {getattr(args, name)}")
    if min(args.sizes) < 1:
        parser.error(f"--sizes must all be >= 1, got {args.sizes}")
    if args.reference_size is not None and not 0 < args.reference_size < math.inf:
        parser.error(f"--reference-size must be a positive number, got {args.reference_size}")
    data_digest, validation_digest = file_digest(args.data), file_digest(args.validation)
    if data_digest and data_digest == validation_digest:
        parser.error("--validation must be another file than --data (the runs train on it)")
    torch.set_num_threads(args.threads)
    data = load_transitions(args.data)
    if max(args.sizes) > len(data):
        parser.error(f"--sizes: {max(args.sizes)} is more than --data's {len(data)} "
                     "transitions")
    validation = load_transitions(args.validation)
    runs = Path(args.runs)
    out = Path(args.out) if args.out else runs
    tc = TransitionTrainConfig(steps=args.steps, eval_every=max(1, args.steps // 4),
                               seed=args.seed)
    depth = args.depth or (TransitionModelConfig.depth if args.architecture == "mlp" else 7)
    if depth < 1:
        parser.error(f"--depth must be >= 1, got {depth}")
    mc = TransitionModelConfig(members=1, contact_reach=0.03, width=args.width,
                               architecture=args.architecture, depth=depth,
                               cord_inputs=args.cord_inputs)
    # a row is fitted with others only if they agree on all of these (the MLP of the shipped
    # depth keeps the settings and names of the runs made before the chain network)
    design = {} if (args.architecture, depth) == ("mlp", TransitionModelConfig.depth) else {
        "architecture": args.architecture, "depth": depth}
    if args.cord_inputs:
        design["cord_inputs"] = True
    suffix = "".join({"architecture": f"-{v}", "depth": f"-d{v}", "cord_inputs": "-cords"}[k]
                     for k, v in design.items())
    settings = {"data": data_digest, "validation": validation_digest, "steps": args.steps,
                "width": args.width, "seed": args.seed, "fit_sample": args.fit_sample, **design}
    for size in sorted(args.sizes):
        run = runs / f"n{size}-s{args.steps}-w{args.width}-seed{args.seed}{suffix}"
        scored = run / "scores.json"
        earlier = json.loads(scored.read_text()) if scored.is_file() else {}
        if earlier.get("data", data_digest) != data_digest:
            raise SystemExit(f"--runs: {run} was trained on another --data file; choose "
                             "another --runs folder")
        subset = first_episodes(data, size)
        # the training time is known only for a run this invocation did from its start
        fresh = not (run / CHECKPOINT_FILE).exists() and not (run / "transition.pt").exists()
        started = time.perf_counter()
        model = train_transition_model(subset, run, tc, mc, resume=True, device="cpu")
        minutes = (round((time.perf_counter() - started) / 60, 2) if fresh
                   else earlier.get("minutes"))
        row = {"size": int(len(subset)), **settings, "minutes": minutes,
               "unseen": scores(model, validation),
               "train": scores(model, trained_sample(subset, tc, args.fit_sample))}
        write_text_atomic(scored, json.dumps(row, indent=1))
        shown = "?" if minutes is None else minutes
        print(f"{row['size']:>8} transitions {shown:>6} min  " + "  ".join(
            f"{g} {row['unseen'][g]['mean_cm']:.3f} cm {100 * row['unseen'][g]['within']:.2f} % "
            f"(train {100 * (1 - misses([row], g, 'train')[0]):.2f} %)"
            for g in GRASP_NAMES if row["unseen"][g]["moves"]), flush=True)

    # every run of these settings under --runs, also those of other invocations
    found = (json.loads(p.read_text()) for p in runs.glob("*/scores.json"))
    rows = sorted((r for r in found if all(r.get(k) == v for k, v in settings.items())),
                  key=lambda r: r["size"])
    tag = f"s{args.steps}-w{args.width}-seed{args.seed}{suffix}"
    write_text_atomic(out / f"scaling-{tag}.json", json.dumps(rows, indent=1))
    sizes = np.array([r["size"] for r in rows], dtype=np.float64)
    print(f"\nmisses on unseen moves ~ N^b, fitted over {len(rows)} sizes "
          f"({int(sizes.min())}-{int(sizes.max())} transitions, width {args.width}{suffix}, "
          f"{args.steps} steps each):")
    fits = {g: power_law(sizes, misses(rows, g)) for g in GRASP_NAMES}
    for g, fit in fits.items():
        exponent = "-" if fit is None else f"{fit[1]:+.2f}"
        print(f"  {g:<5} b = {exponent:>6}; within 1 cm >= {100 * WITHIN_FLOORS[g]:.1f} %: "
              f"{transitions(needed(fit, WITHIN_FLOORS[g]))}")
    reference = scores(TransitionModel.load_or_pretrained(args.reference, device="cpu"),
                       validation)
    name = args.reference or "shipped model"
    reference_misses = {g: misses([{"unseen": reference}], g)[0] for g in GRASP_NAMES}
    print(f"the {name} on the same moves (misses as one network on ... of this kind):")
    for g in GRASP_NAMES:
        print(f"  {g:<5} {reference[g]['mean_cm']:.3f} cm, "
              f"{100 * (1 - reference_misses[g]):.2f} % within 1 cm: "
              f"{transitions(size_for(fits[g], reference_misses[g]))}")

    def finite(n: float) -> float | None:  # JSON has no infinity
        return n if math.isfinite(n) else None

    write_text_atomic(out / f"scaling-fit-{tag}.json", json.dumps({
        "settings": settings,
        "reference": {"model": args.reference or "shipped", **reference},
        **{g: None if f is None else {
            "a": f[0], "b": f[1], "needed": finite(needed(f, WITHIN_FLOORS[g])),
            "reference_as": finite(size_for(f, reference_misses[g]))}
           for g, f in fits.items()}}, indent=1))

    plot_scaling(
        sizes, {g: misses(rows, g) for g in GRASP_NAMES},
        {g: misses(rows, g, "train") for g in GRASP_NAMES},
        fits, WITHIN_FLOORS, out / f"scaling-{tag}.png",
        f"one network of width {args.width}{suffix}, {args.steps} steps each; dashed: the "
        "power law; dash-dot: the floors",
        None if args.reference_size is None else (args.reference_size, reference_misses, name))
    print(f"wrote {out}/scaling-{tag}.json, scaling-fit-{tag}.json and scaling-{tag}.png")


if __name__ == "__main__":
    main()
