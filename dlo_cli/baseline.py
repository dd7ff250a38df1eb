"""``dlo baseline``: train a Stable-Baselines3 agent (PPO, SAC, SAC + HER) on the cord."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Flags of ``dlo baseline`` (they map onto ``planners.rl_baseline.BaselineConfig``)."""
    parser.add_argument("--algo", choices=("ppo", "sac", "sac-her"), required=True)
    parser.add_argument("--timesteps", type=int, default=300_000,
                        help="environment steps of training, summed over environments "
                             "(default 300000)")
    parser.add_argument("--n-envs", type=int, default=2, help="environments (default 2)")
    parser.add_argument("--subprocess", action="store_true",
                        help="step the environments in subprocesses (needs a free core each)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--difficulty", type=int, nargs="+", default=[1, 2, 3], metavar="K",
                        help="task difficulties to train on, one drawn per episode "
                             "(default 1 2 3)")
    parser.add_argument("--reward-type", choices=("dense", "sparse"), default="dense")
    parser.add_argument("--env-id", default="dlo_env/DLOEndpoint-v0")
    parser.add_argument("--set", nargs="+", default=[], metavar="FIELD=VALUE",
                        help="other BaselineConfig fields, values in JSON "
                             "(e.g. ppo_n_steps=512 net_arch=[64,64])")
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument("--resume", action="store_true",
                        help="continue an interrupted run from OUT/checkpoint.zip")
    parser.add_argument("--device", default="cpu", help="cpu (default) or cuda")
    parser.add_argument("--threads", type=int, default=1,
                        help="torch CPU threads (default 1: small networks, shared machine)")


def _overrides(items: list[str]) -> dict:
    import json

    values = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep:
            raise ValueError(f"--set takes FIELD=VALUE, got {item!r}")
        try:
            values[key] = json.loads(text)
        except json.JSONDecodeError:
            values[key] = text  # a bare string
    return values


def run(args: argparse.Namespace) -> int:
    """Train, save and summarise one baseline."""
    import json
    import sys
    from dataclasses import asdict
    from pathlib import Path

    from planners.rl_baseline import (
        BaselineConfig,
        ResumeMismatch,
        read_monitor_logs,
        train_baseline,
    )

    try:
        settings = dict(
            algo=args.algo, env_id=args.env_id, difficulties=list(args.difficulty),
            reward_type=args.reward_type, timesteps=args.timesteps, n_envs=args.n_envs,
            subprocess=args.subprocess, seed=args.seed,
        )
        settings.update(_overrides(args.set))
        config = BaselineConfig.from_dict(settings)
    except (ValueError, TypeError) as exc:
        print(f"dlo baseline: {exc}", file=sys.stderr)
        return 2
    out = Path(args.out)
    print(f"training {config.algo} on {config.env_id} (difficulties {config.difficulties}) for "
          f"{config.timesteps} steps with {config.n_envs} envs -> {out}")
    print("config: " + json.dumps(asdict(config)), flush=True)
    try:
        path = train_baseline(config, out, device=args.device, resume=args.resume,
                              threads=args.threads)
    except ResumeMismatch as exc:
        print(f"dlo baseline: {exc}", file=sys.stderr)
        return 2
    meta = json.loads((out / "hyperparameters.json").read_text())
    logs = read_monitor_logs(out / "monitor")
    last = slice(-100, None)
    success = float(logs["is_success"][last].mean()) if len(logs["reward"]) else float("nan")
    ret = float(logs["reward"][last].mean()) if len(logs["reward"]) else float("nan")
    print(f"done: {meta['trained_timesteps']} steps in {meta['train_seconds']:.0f} s; "
          f"last 100 training episodes: success {success:.2f}, return {ret:.2f}")
    print(f"model: {path}\ncurve: {out / 'learning_curve.png'}")
    return 0
