"""Make the shipped transition model from scratch: the data, the ensemble, its mean network.

One command runs the whole documented recipe, each step through the ``dlo`` command line:
collect the training files and the held-out file (``dlo collect --kind transitions``; a file
already there is reused when its settings are the recipe's), train the ensemble, then distil
its mean network (``dlo train --stage transition``). Every step resumes where a killed run
stopped, so the same command continues it. About 2.8 hours on 2 cores (collection 30 min,
the ensemble 95, the mean network 15). Nothing tracked is written; to ship the result:

    python examples/make_transition_model.py --out runs/transition-recipe
    cp runs/transition-recipe/mean/transition.pt \
       runs/transition-recipe/mean/transition-metrics.* latent_model/pretrained/

``--scale`` shrinks every count (transitions and steps) for a quick trial of the pipeline;
its files then default to ``runs/transition-recipe-scale-S/`` (data and models), so a trial
never meets the full recipe's files. Default paths are the repository's, wherever it runs.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from dlo_cli.flags import positive_int

ROOT = Path(__file__).resolve().parents[1]

#: The shipped data: (file name, transitions, seed, share of wide starts). The first files
#: train; the last is the held-out file of the reports (never trained on or tuned with).
DATA = (
    ("transitions-train.npz", 60_000, 0, 0.0),
    ("transitions-train-2.npz", 40_000, 2, 0.0),
    ("transitions-train-3.npz", 60_000, 3, 1.0),
    ("transitions-train-5.npz", 60_000, 5, 0.5),
    ("transitions-train-6.npz", 60_000, 6, 0.5),
    ("transitions-heldout.npz", 6_000, 1, 0.0),
)
#: Training steps of the ensemble; of the mean network, with its learning rate and the
#: teacher-labelled moves per training transition (``--teacher-moves``).
ENSEMBLE_STEPS = 200_000
MEAN_STEPS, MEAN_LR, MEAN_TEACHER_MOVES = 100_000, 5e-4, 1


def dlo(*argv: object) -> None:
    """Run one ``dlo`` command in this process; a failure stops the recipe with its code."""
    from dlo_cli.main import main

    argv = [str(a) for a in argv]
    print("$ dlo " + " ".join(argv), flush=True)
    code = main(argv)
    if code:
        raise SystemExit(code)


def mismatch(path: Path, count: int, seed: int, wide: float) -> str | None:
    """Why the file at ``path`` is not the recipe's (one line), or None if it is."""
    from dlo_env.dataset.transitions import TransitionCollectConfig, load_transitions

    try:
        data = load_transitions(path)
    except (ValueError, OSError) as exc:
        return f"{path} cannot be read: {exc}"
    # Every setting as the recipe's; one a file predates was its default then and now.
    want = TransitionCollectConfig(seed=seed, wide_fraction=wide).to_json()
    made = {**TransitionCollectConfig().to_json(), **data.metadata.get("collect", {})}
    differ = [k for k in want if made.get(k) != want[k]] + ([] if len(data) == count
                                                           else ["transitions"])
    if differ:
        return (f"{path} is not the recipe's file ({count} transitions, seed {seed}, wide "
                f"fraction {wide}): {', '.join(differ)} differ")
    return None


def collect(path: Path, count: int, seed: int, wide: float, workers: int) -> None:
    """``path`` holding the recipe's transitions: collected (or resumed) unless there."""
    if path.exists():
        print(f"{path}: there, {count} transitions as the recipe says", flush=True)
        return
    dlo("collect", "--kind", "transitions", "--num-transitions", count, "--seed", seed,
        "--wide-fraction", wide, "--workers", workers, "--out", path, "--resume")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None,
                        help="folder of the ensemble (ensemble/) and the mean network (mean/); "
                             "default runs/transition-recipe (with --scale: "
                             "runs/transition-recipe-scale-S)")
    parser.add_argument("--data-dir", type=Path, default=None,
                        help="where the transition files are read or collected; default data "
                             "(with --scale: OUT/data)")
    parser.add_argument("--workers", type=positive_int, default=2, help="collection processes")
    parser.add_argument("--threads", type=positive_int, default=2,
                        help="torch threads of training")
    parser.add_argument("--scale", type=float, default=1.0,
                        help="multiply every count (transitions, steps) by this, in (0, 1]")
    args = parser.parse_args(argv)
    if not 0 < args.scale <= 1:
        parser.error(f"--scale must be in (0, 1], got {args.scale}")
    trial = "" if args.scale == 1 else f"-scale-{args.scale:g}"
    out = args.out or ROOT / "runs" / f"transition-recipe{trial}"
    data_dir = args.data_dir or (out / "data" if trial else ROOT / "data")

    def scaled(n: int) -> int:
        return max(1, round(n * args.scale))

    files = [data_dir / name for name, *_ in DATA]
    # Every file already there is checked before anything is collected or trained.
    wrong = [why for path, (_, count, seed, wide) in zip(files, DATA) if path.exists()
             if (why := mismatch(path, scaled(count), seed, wide))]
    if wrong:
        raise SystemExit("; ".join(wrong) + "; move them away or pass another --data-dir")
    data_dir.mkdir(parents=True, exist_ok=True)
    for path, (_, count, seed, wide) in zip(files, DATA):
        collect(path, scaled(count), seed, wide, args.workers)
    train, heldout = files[:-1], files[-1]
    common = ["--data", *train, "--heldout", heldout, "--threads", args.threads]
    ensemble, mean = out / "ensemble", out / "mean"
    dlo("train", "--stage", "transition", "--steps", scaled(ENSEMBLE_STEPS),
        "--out", ensemble, *common)
    dlo("train", "--stage", "transition", "--teacher", ensemble / "transition.pt",
        "--steps", scaled(MEAN_STEPS), "--lr", MEAN_LR, "--teacher-moves", MEAN_TEACHER_MOVES,
        "--out", mean, *common)
    print(f"the model: {mean / 'transition.pt'}; to ship it: cp {mean}/transition.pt "
          f"{mean}/transition-metrics.* latent_model/pretrained/")


if __name__ == "__main__":
    main()
