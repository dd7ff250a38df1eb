"""``dlo baseline``: train a Stable-Baselines3 agent (PPO, SAC, SAC + HER) on the cord."""

from __future__ import annotations

import argparse

from dlo_cli.flags import (
    add_device,
    add_difficulty,
    add_env,
    add_seed,
    add_threads,
    number_in,
    positive_int,
    writable_folder,
)
from dlo_env.errors import InputError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Flags of ``dlo baseline``; defaults are ``dlo_bench.baselines.BaselineConfig``'s."""
    from dlo_bench.baselines import ALGOS, CORDS, BaselineConfig
    from dlo_env.cord import MAX_PEGS

    parser.add_argument("--algo", choices=ALGOS, required=True, help="the algorithm")
    parser.add_argument("--timesteps", type=positive_int, default=BaselineConfig.timesteps,
                        help="environment steps of training, summed over environments")
    parser.add_argument("--n-envs", type=positive_int, default=BaselineConfig.n_envs,
                        help="environments")
    parser.add_argument("--subprocess", action="store_true",
                        help="step the environments in subprocesses (needs a free core each)")
    add_seed(parser, "the agent and the environments")
    add_difficulty(parser, list(BaselineConfig.difficulties),
                   "training draws one per episode (1 to 5: episodes of 100 steps)", maximum=5)
    parser.add_argument("--reward-type", choices=("dense", "sparse"),
                        default=BaselineConfig.reward_type, help="the environment's reward")
    add_env(parser, BaselineConfig.env_id, "the environment it trains in", dest="env_id",
            alias=True)
    parser.add_argument("--cords", choices=CORDS, default=BaselineConfig.cords,
                        help="the cords it trains on: fixed, the environment's own in every "
                             "episode; train, a cord drawn each episode from the ranges of "
                             "docs/cords.md away from the held-out test cords, not told to the "
                             "policy (the shipped sac-her-cords)")
    parser.add_argument("--max-pegs", type=number_in(int, 0, MAX_PEGS, expected=f"an integer "
                                                     f"from 0 to {MAX_PEGS}"),
                        default=BaselineConfig.max_pegs, metavar="N",
                        help="train with 0 to N pegs near every start, observed in N slots "
                             "(default 0: the empty table)")
    parser.add_argument("--success-threshold", type=number_in(float, 0.0, None, low_open=True,
                                                              expected="a number of metres > 0"),
                        default=BaselineConfig.success_threshold, metavar="METRES",
                        help="episodes end within this of the goal while training (default "
                             "0.02; the benchmark scores at 0.02, 0.01 and 0.005)")
    parser.add_argument("--surrogate", action="store_true",
                        help="train in the environment's learned twin (n-envs cords stepped "
                             "in one batched call of the transition model; no pymunk steps); "
                             "the agent acts in the environment (default out: ALGO-surrogate)")
    parser.add_argument("--set", nargs="+", action="extend", default=[], metavar="FIELD=VALUE",
                        help="other BaselineConfig fields, values in JSON "
                             "(e.g. ppo_n_steps=512 net_arch=[64,64])")
    parser.add_argument("--out", default=None,
                        help="output folder (None: runs/baseline/NAME, the folder name "
                             "dlo benchmark looks for: ALGO, ALGO-cords with --cords train, "
                             "ALGO-pegs with --max-pegs, and -dual-endpoint in "
                             "DLODualEndpoint-v0)")
    parser.add_argument("--resume", action="store_true",
                        help="continue an interrupted run from OUT/checkpoint.zip")
    add_device(parser, "cpu")
    add_threads(parser)


#: Printed after Ctrl-C.
ON_INTERRUPT = ("the run continues from its last checkpoint (OUT/checkpoint.zip, written every "
                "checkpoint_every steps, if one was) when the same command is run again with "
                "--resume")

#: ``BaselineConfig`` fields with a flag of their own: ``--set`` leaves them to it, so the flag's
#: checks always apply.
FLAG_FIELDS = {"algo": "--algo", "env_id": "--env", "difficulties": "--difficulty",
               "reward_type": "--reward-type", "timesteps": "--timesteps", "n_envs": "--n-envs",
               "subprocess": "--subprocess", "seed": "--seed", "cords": "--cords",
               "max_pegs": "--max-pegs", "success_threshold": "--success-threshold",
               "surrogate": "--surrogate"}


def field_flags() -> dict[str, str]:
    """``BaselineConfig`` field -> the flag that sets it: its own flag, else ``--set FIELD``."""
    from dataclasses import fields

    from dlo_bench.baselines import BaselineConfig

    return {f.name: FLAG_FIELDS.get(f.name, f"--set {f.name}") for f in fields(BaselineConfig)}


def _overrides(items: list[str]) -> dict:
    import json
    from dataclasses import fields

    from dlo_bench.baselines import BaselineConfig

    others = [f.name for f in fields(BaselineConfig) if f.name not in FLAG_FIELDS]
    values = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep:
            raise InputError(f"--set takes FIELD=VALUE, got {item!r}")
        if key in FLAG_FIELDS:
            raise InputError(f"--set {key}: give it with {FLAG_FIELDS[key]}")
        if key not in others:
            raise InputError(f"--set {key}: unknown key; the fields --set takes are "
                             f"{', '.join(others)}")
        try:
            values[key] = json.loads(text)
        except json.JSONDecodeError:
            values[key] = text  # a bare string
    return values


def run(args: argparse.Namespace) -> int:
    """Train, save and summarise one baseline."""
    import json
    from dataclasses import asdict
    from pathlib import Path

    import stable_baselines3  # noqa: F401  (first, so a core install is told to add the rl extra)

    from dlo_bench.baselines import (
        BaselineConfig,
        check_out_folder,
        read_monitor_logs,
        train_baseline,
    )
    from dlo_bench.paths import baseline_folder_name, default_out

    settings = dict(
        algo=args.algo, env_id=args.env_id, difficulties=list(args.difficulty),
        reward_type=args.reward_type, timesteps=args.timesteps, n_envs=args.n_envs,
        subprocess=args.subprocess, seed=args.seed, cords=args.cords,
        max_pegs=args.max_pegs, success_threshold=args.success_threshold,
        surrogate=args.surrogate,
    )
    settings.update(_overrides(args.set))
    try:
        config = BaselineConfig.from_dict(settings)
    except TypeError as exc:  # a --set value of the wrong type
        raise InputError(f"--set: {exc}") from exc
    # the benchmark's folder names (sac-her-pegs-dual-endpoint...)
    name = baseline_folder_name(config.algo + ("-cords" if config.cords == "train" else "")
                                + ("-surrogate" if config.surrogate else ""),
                                config.env_id, pegs=bool(config.max_pegs))
    out = Path(args.out) if args.out else default_out("baseline") / name
    resuming = check_out_folder(out, args.resume, "--out")
    writable_folder(out)
    if args.resume and not resuming:
        print(f"no checkpoint.zip in {out}: training from the start")
    print(f"training {config.algo} on {config.env_id} (difficulties {config.difficulties}, "
          f"{config.cords} cords, "
          f"{f'up to {config.max_pegs} pegs' if config.max_pegs else 'no pegs'}) for "
          f"{config.timesteps} {'surrogate' if config.surrogate else 'env'} steps with "
          f"{config.n_envs} envs -> {out}")
    print("config: " + json.dumps(asdict(config)), flush=True)
    path = train_baseline(config, out, device=args.device, resume=args.resume,
                          threads=args.threads)
    meta = json.loads((out / "hyperparameters.json").read_text())
    logs = read_monitor_logs(out / "monitor")
    last = slice(-100, None)
    success = float(logs["is_success"][last].mean()) if len(logs["reward"]) else float("nan")
    ret = float(logs["reward"][last].mean()) if len(logs["reward"]) else float("nan")
    print(f"done: {meta['trained_timesteps']} steps in {meta['train_seconds']:.0f} s; "
          f"last 100 training episodes: success {success:.2f}, return {ret:.2f}")
    print(f"model: {path}\ncurve: {out / 'learning_curve.png'}")
    return 0
