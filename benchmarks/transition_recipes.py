"""Training recipes of the transition model at equal time: what the training time buys.

The model is limited by training time, so a recipe is judged by its error after as much time,
not as many steps. Each recipe trains one network (``members=1``) on one thread from the same
seed and data, and is scored on a validation file none of them trained on:

- ``chain``: the one-move loss plus the loss on rolled-out 2-3 move chains (weight 0.5, the
  recipe of the models before mirror), ``--chain-steps`` steps;
- ``one-move``: the one-move loss alone, ``--steps`` steps (a step costs about half a chain
  step, so the defaults take a little less time than ``chain``'s);
- ``one-move + mirror``: the same, one handedness (``TransitionModelConfig.mirror``).

Prints, per recipe, the minutes and the one-, two- and three-move mean errors by grasp::

    python benchmarks/transition_recipes.py --data data/transitions-train.npz \\
        data/transitions-train-2.npz data/transitions-train-3.npz \\
        --validation data/transitions-val-4.npz [--chain-steps 8000 --steps 13000]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import torch

from dlo_env.atomic import write_text_atomic
from dlo_env.dataset.transitions import GRASP_NAMES, load_transition_files, load_transitions
from latent_model.transition_metrics import transition_report
from latent_model.transition_model import TransitionModelConfig
from latent_model.transition_training import TransitionTrainConfig, train_transition_model


def recipes(chain_steps: int, steps: int) -> dict[str, tuple[TransitionTrainConfig,
                                                             TransitionModelConfig]]:
    """The recipes compared: name -> (training, model) settings."""
    one = TransitionModelConfig(members=1, mirror=False)
    return {
        "chain": (TransitionTrainConfig(steps=chain_steps, eval_every=chain_steps,
                                        chain_weight=0.5), one),
        "one-move": (TransitionTrainConfig(steps=steps, eval_every=steps, chain_weight=0.0), one),
        "one-move + mirror": (TransitionTrainConfig(steps=steps, eval_every=steps,
                                                    chain_weight=0.0),
                              TransitionModelConfig(members=1, mirror=True)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", nargs="+", default=["data/transitions-train.npz"])
    parser.add_argument("--validation", default="data/transitions-val-4.npz",
                        help="transitions none of the recipes trained on (not the held-out "
                             "file of the floors: recipes are chosen here)")
    parser.add_argument("--chain-steps", type=int, default=8000)
    parser.add_argument("--steps", type=int, default=13000)
    parser.add_argument("--only", nargs="+", default=None, choices=list(recipes(1, 1)),
                        help="run only these recipes")
    parser.add_argument("--out", default="runs/transition-recipes")
    args = parser.parse_args()
    torch.set_num_threads(1)
    data = load_transition_files(args.data)
    validation = load_transitions(args.validation)
    summary = Path(args.out) / "recipes.json"
    results = json.loads(summary.read_text()) if summary.is_file() else {}
    for name, (tc, mc) in recipes(args.chain_steps, args.steps).items():
        if args.only and name not in args.only:
            continue
        key = f"{name.replace(' + ', '-')}-{tc.steps}"
        out = Path(args.out) / key
        done = (out / "transition.pt").is_file()  # trained by an earlier run: its time stands
        started = time.perf_counter()
        model = train_transition_model(data, out, tc, mc, resume=True, device="cpu")
        minutes = (results.get(key, {}).get("minutes") if done
                   else round((time.perf_counter() - started) / 60, 2))
        row = {"recipe": name, "steps": tc.steps, "minutes": minutes}
        rows, _ = transition_report(model, validation)
        row.update({f"{r.moves}_{r.group}_cm": r.mean_cm for r in rows if r.group in GRASP_NAMES})
        results[key] = row
        shown = "   ?" if minutes is None else f"{minutes:5.1f}"
        print(f"{name:<18} {tc.steps:>6} steps {shown} min   " + "   ".join(
            f"{k} moves " + " / ".join(f"{row[f'{k}_{g}_cm']:.3f}" for g in GRASP_NAMES)
            for k in (1, 2, 3)) + " cm (head / tail / both)", flush=True)
    write_text_atomic(summary, json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
