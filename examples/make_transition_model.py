"""Make the shipped transition model from scratch: the data, the ensemble, its mean network.

One command runs the whole documented recipe, each step through the ``dlo`` command line:
collect the training files and the held-out file (``dlo collect transitions``; a file
already there is reused when its settings are the recipe's), then the trainings of
``TRAININGS`` in order (``dlo train transition``): the ensemble, the same ensemble
fine-tuned on one more file, then on two more, then on one more, once more on one more
(half of its starts from ``wavy_cord_shape``), once more on one more (half of its moves
aimed at the rim), and once more on one more (wavy starts, both ends held, moves that push
the cord together) with misses beyond 0.5 cm weighted 5 times, once more on the same files,
the misses weighted the same, with contact vectors added (``--contact-reach 0.03``: a sharp
rim vector per point and target, their weights starting at zero), then its mean network by
grasp distilled from it, the misses weighted the same. Every step resumes where a killed run
stopped, so the same command continues it. About 8.5 hours on 2 cores (collection 92 min, the
ensemble 94, the fine-tunings 31, 31, 37, 33, 34, 34 and 39, the mean network 75).
Nothing tracked is written; to ship the result:

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
from typing import Any

from dlo_cli.flags import positive_int

ROOT = Path(__file__).resolve().parents[1]

#: The shipped data: (file name, transitions, collection settings of
#: ``TransitionCollectConfig``; the others are its defaults). The last file is the held-out
#: file of the reports (never trained on or tuned with).
DATA: tuple[tuple[str, int, dict[str, Any]], ...] = (
    ("transitions-train.npz", 60_000, {"seed": 0}),
    ("transitions-train-2.npz", 40_000, {"seed": 2}),
    ("transitions-train-3.npz", 60_000, {"seed": 3, "wide_fraction": 1.0}),
    ("transitions-train-5.npz", 60_000, {"seed": 5, "wide_fraction": 0.5}),
    ("transitions-train-6.npz", 60_000, {"seed": 6, "wide_fraction": 0.5}),
    ("transitions-train-7.npz", 80_000, {"seed": 7, "wide_fraction": 0.5,
                                         "grasp_weights": (0.2, 0.2, 0.6), "rim_fraction": 0.2}),
    ("transitions-train-8.npz", 80_000, {"seed": 8, "wide_fraction": 0.5,
                                         "grasp_weights": (0.1, 0.1, 0.8), "rim_fraction": 0.2}),
    ("transitions-train-9.npz", 80_000, {"seed": 9, "wide_fraction": 0.5,
                                         "grasp_weights": (0.25, 0.25, 0.5),
                                         "rim_fraction": 0.2}),
    ("transitions-train-10.npz", 80_000, {"seed": 10, "wide_fraction": 0.5,
                                          "grasp_weights": (0.2, 0.2, 0.6),
                                          "rim_fraction": 0.2}),
    ("transitions-train-11.npz", 80_000, {"seed": 11, "wavy_fraction": 0.5, "wide_fraction": 0.25,
                                          "grasp_weights": (0.15, 0.15, 0.7),
                                          "rim_fraction": 0.2}),
    ("transitions-train-12.npz", 80_000, {"seed": 12, "wavy_fraction": 0.25,
                                          "wide_fraction": 0.25,
                                          "grasp_weights": (0.4, 0.4, 0.2),
                                          "rim_fraction": 0.5}),
    ("transitions-train-13.npz", 80_000, {"seed": 13, "wavy_fraction": 0.75,
                                          "grasp_weights": (0.15, 0.15, 0.7),
                                          "push_fraction": 0.5, "rim_fraction": 0.1}),
    ("transitions-heldout.npz", 6_000, {"seed": 1}),
)
#: The trainings, in order: (folder, how many of DATA's first files it trains on, settings of
#: ``TransitionTrainConfig``, and of the architecture: ``contact_reach`` of an ensemble,
#: ``mean_by_grasp`` of a distilled model).
#: ``teacher`` and ``init`` name an earlier training's folder.
TRAININGS: tuple[tuple[str, int, dict[str, Any]], ...] = (
    ("ensemble", 5, {"steps": 200_000}),
    ("finetune", 6, {"init": "ensemble", "steps": 100_000, "lr": 5e-4}),
    ("finetune2", 8, {"init": "finetune", "steps": 100_000, "lr": 5e-4}),
    ("finetune3", 9, {"init": "finetune2", "steps": 100_000, "lr": 5e-4}),
    ("finetune4", 10, {"init": "finetune3", "steps": 100_000, "lr": 5e-4}),
    ("finetune5", 11, {"init": "finetune4", "steps": 100_000, "lr": 5e-4}),
    ("finetune6", 12, {"init": "finetune5", "steps": 100_000, "lr": 5e-4, "miss_weight": 4.0}),
    ("finetune7", 12, {"init": "finetune6", "steps": 100_000, "lr": 5e-4, "miss_weight": 4.0,
                       "contact_reach": 0.03}),
    ("mean", 12, {"teacher": "finetune7", "mean_by_grasp": True, "steps": 600_000, "lr": 5e-4,
                 "teacher_moves": 1, "miss_weight": 4.0}),
)
#: The training whose model ships.
SHIPPED = TRAININGS[-1][0]


def dlo(*argv: object) -> None:
    """Run one ``dlo`` command in this process; a failure stops the recipe with its code."""
    from dlo_cli.main import main

    argv = [str(a) for a in argv]
    print("$ dlo " + " ".join(argv), flush=True)
    code = main(argv)
    if code:
        raise SystemExit(code)


def flags(settings: dict[str, Any]) -> list[object]:
    """``--name value...`` of settings (a tuple gives several values; True a bare switch)."""
    out: list[object] = []
    for key, value in settings.items():
        if value is False:
            continue
        if value is True:
            values: list[object] = []
        else:
            values = list(value) if isinstance(value, (tuple, list)) else [value]
        out += [f"--{key.replace('_', '-')}", *values]
    return out


def short(path: Path) -> Path:
    """``path`` relative to the working directory when inside it (what a model records)."""
    try:
        return path.resolve().relative_to(Path.cwd().resolve())
    except ValueError:
        return path


def mismatch(path: Path, count: int, settings: dict[str, Any]) -> str | None:
    """Why the file at ``path`` is not the recipe's (one line), or None if it is."""
    from dlo_env.dataset.transitions import TransitionCollectConfig, load_transitions

    try:
        data = load_transitions(path)
    except (ValueError, OSError) as exc:
        return f"{path} cannot be read: {exc}"
    # Every setting as the recipe's; one a file predates was its default then and now.
    want = TransitionCollectConfig(**settings).to_json()
    made = {**TransitionCollectConfig().to_json(), **data.metadata.get("collect", {})}
    differ = [k for k in want if made.get(k) != want[k]] + ([] if len(data) == count
                                                           else ["transitions"])
    if differ:
        said = ", ".join(f"{k} {v}" for k, v in settings.items())
        return (f"{path} is not the recipe's file ({count} transitions, {said}): "
                f"{', '.join(differ)} differ")
    return None


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None,
                        help="folder of the trainings (ensemble/, mean/); default "
                             "runs/transition-recipe (with --scale: "
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

    files = [short(data_dir / name) for name, *_ in DATA]
    # Every file already there is checked before anything is collected or trained.
    wrong = [why for path, (_, count, settings) in zip(files, DATA) if path.exists()
             if (why := mismatch(path, scaled(count), settings))]
    if wrong:
        raise SystemExit("; ".join(wrong) + "; move them away or pass another --data-dir")
    data_dir.mkdir(parents=True, exist_ok=True)
    for path, (_, count, settings) in zip(files, DATA):
        if path.exists():
            print(f"{path}: there, {scaled(count)} transitions as the recipe says", flush=True)
        else:
            dlo("collect", "transitions", "--num-transitions", scaled(count),
                *flags(settings), "--workers", args.workers, "--out", path, "--resume")
    heldout, out = files[-1], short(out)
    for folder, used, settings in TRAININGS:
        settings = {**settings, "steps": scaled(settings["steps"])}
        for key in ("teacher", "init"):  # an earlier training's model
            if key in settings:
                settings[key] = out / settings[key] / "transition.pt"
        dlo("train", "transition", *flags(settings), "--data", *files[:used],
            "--heldout", heldout, "--threads", args.threads, "--out", out / folder)
    shipped = out / SHIPPED
    print(f"the model: {shipped / 'transition.pt'}; to ship it: cp {shipped}/transition.pt "
          f"{shipped}/transition-metrics.* {ROOT / 'latent_model' / 'pretrained'}/")


if __name__ == "__main__":
    main()
