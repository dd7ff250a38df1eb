"""``dlo baseline``: train a Stable-Baselines3 agent (PPO, SAC, SAC + HER) on the cord."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Flags of ``dlo baseline`` (they map onto ``planners.rl_baseline.BaselineConfig``)."""
    parser.add_argument("--algo", choices=("ppo", "sac", "sac-her"), required=True)
    parser.add_argument("--timesteps", type=int, default=200_000,
                        help="environment steps of training (default 200000)")
    parser.add_argument("--n-envs", type=int, default=4, help="parallel environments")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--difficulty", type=int, default=1, help="task difficulty 1-5")
    parser.add_argument("--env-id", default="dlo_env/DLOEndpoint-v0")
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument("--device", default="auto", help="auto, cpu or cuda")


def run(args: argparse.Namespace) -> int:
    """Train, save and summarise one baseline."""
    import json
    from pathlib import Path

    from planners.rl_baseline import BaselineConfig, read_monitor_logs, train_baseline

    config = BaselineConfig(
        algo=args.algo, env_id=args.env_id, difficulty=args.difficulty,
        timesteps=args.timesteps, n_envs=args.n_envs, seed=args.seed,
    )
    out = Path(args.out)
    print(f"training {config.algo} on {config.env_id} (difficulty {config.difficulty}) for "
          f"{config.timesteps} steps with {config.n_envs} envs -> {out}")
    path = train_baseline(config, out, device=args.device)
    meta = json.loads((out / "hyperparameters.json").read_text())
    logs = read_monitor_logs(out / "monitor")
    last = slice(-100, None)
    success = float(logs["is_success"][last].mean()) if len(logs["reward"]) else float("nan")
    ret = float(logs["reward"][last].mean()) if len(logs["reward"]) else float("nan")
    print(f"done: {meta['trained_timesteps']} steps in {meta['train_seconds']:.0f} s; "
          f"last 100 training episodes: success {success:.2f}, return {ret:.2f}")
    print(f"model: {path}\ncurve: {out / 'learning_curve.png'}")
    return 0
