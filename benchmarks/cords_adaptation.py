"""How many moves latent-mpc-adaptive needs to know a cord: prediction error against moves seen.

For episodes of the held-out test cords (a file of ``dlo collect transitions
--test-cords``: episodes of a few moves, each episode one cord and one grasp), the cord is
fitted as ``AdaptiveLatentMPCPolicy`` fits it (its length read off the first shape, the rest by
``AdaptiveLatentMPCPolicy.fit``) to the episode's first k moves, k = 0 (the default cord at the
observed length) to the episode's length, each k fitted afresh (the policy starts each fit from
its last); the fitted cord then predicts ``--probe`` moves of
the same cord and grasp from other episodes. Printed per k: the mean one-move error with the
fitted cord, beside the same model told the true cord, and how far the fitted parameters lie
from the true ones (mean absolute log ratio).

    python benchmarks/cords_adaptation.py --data data/cords-test.npz \\
        [--model FILE] [--episodes 8] [--probe 200] [--out runs/cords-adaptation]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch

from dlo_env.core.atomic import write_text_atomic
from dlo_env.dataset.transitions import GRASP_NAMES, PARAM_COLUMNS, load_transitions
from dlo_env.shapes import cord_length, error
from latent_model.transition_model import TransitionModel
from planners.adaptive_mpc import AdaptiveLatentMPCPolicy, _Move


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True, help="moves of the test cords (--test-cords)")
    parser.add_argument("--model", default=None,
                        help="transition model of several cords (default: the shipped one)")
    parser.add_argument("--episodes", type=int, default=8,
                        help="episodes fitted per test cord and grasp kind (one end, both)")
    parser.add_argument("--probe", type=int, default=200,
                        help="moves of the same cord and grasp each fitted cord predicts")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default="runs/cords-adaptation", help="results folder")
    args = parser.parse_args()
    if args.episodes < 1 or args.probe < 1:
        parser.error("--episodes and --probe must be >= 1")
    torch.set_num_threads(1)
    model = TransitionModel.load_or_pretrained(args.model, device="cpu", cords=True)
    data = load_transitions(args.data)
    rng = np.random.default_rng(args.seed)
    policies = {name: AdaptiveLatentMPCPolicy(model, grasp=name) for name in GRASP_NAMES}
    length_col = PARAM_COLUMNS.index("length")
    rows: dict[str, dict[int, list[tuple[float, float, float]]]] = {"one end": {}, "both": {}}
    cords = np.unique(data.params, axis=0)
    for cord in cords:
        on_cord = np.all(data.params == cord, axis=1)
        for group, codes in (("one end", (0, 1)), ("both", (2,))):
            mine = on_cord & np.isin(data.grasp, codes)
            episodes = np.unique(data.episode[mine])
            if len(episodes) < 2:
                continue
            for e in rng.choice(episodes, min(args.episodes, len(episodes) - 1), replace=False):
                idx = np.flatnonzero(mine & (data.episode == e))
                idx = idx[np.argsort(data.step[idx])]
                grasp = GRASP_NAMES[int(data.grasp[idx[0]])]
                probe = np.flatnonzero(mine & (data.episode != e) & (data.grasp == data.grasp[
                    idx[0]]))
                if not len(probe):  # no other episode of this cord and grasp to predict
                    continue
                probe = rng.choice(probe, min(args.probe, len(probe)), replace=False)
                policy = policies[grasp]
                policy.reset()
                start = data.start[idx[0]]
                policy.cord_row[length_col] = cord_length(start)
                moves = [_Move(data.start[i], data.end_displacement(i[None])[0], data.next[i])
                         for i in idx]
                shifts = data.end_displacement(probe)
                true_err = error(model.predict(data.start[probe], grasp, shifts,
                                               params=data.params[probe]), data.next[probe])
                for k in range(len(moves) + 1):
                    fitted = policy.fit(moves[:k])[0] if k else policy.cord_row.copy()
                    pred = model.predict(data.start[probe], grasp, shifts,
                                         params=np.tile(fitted, (len(probe), 1)))
                    gap = float(np.mean(np.abs(np.log(fitted / cord))))
                    rows[group].setdefault(k, []).append(
                        (float(error(pred, data.next[probe]).mean()), float(true_err.mean()),
                         gap))
    result = {}
    for group, by_k in rows.items():
        print(f"\n{group}: moves seen -> one-move error with the fitted cord (the true cord), "
              f"parameters' mean |log ratio|, over {len(by_k.get(0, []))} episodes")
        print("| moves seen | fitted cord | true cord | mean abs log ratio |\n|---|---|---|---|")
        result[group] = {}
        for k in sorted(by_k):
            fitted, true, gap = np.mean(by_k[k], axis=0)
            result[group][k] = {"fitted_cm": 100 * fitted, "true_cm": 100 * true, "gap": gap,
                                "episodes": len(by_k[k])}
            print(f"| {k} | {100 * fitted:.2f} cm | {100 * true:.2f} cm | {gap:.2f} |")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out / "cords_adaptation.json", json.dumps(
        {"data": args.data, "model": args.model or "shipped", "result": result}, indent=1))
    print(f"wrote {out / 'cords_adaptation.json'}")


if __name__ == "__main__":
    main()
