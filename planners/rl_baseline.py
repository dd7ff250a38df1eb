"""Model-free RL baselines with Stable-Baselines3: PPO, SAC and SAC + HER.

``train_baseline`` trains one of them on a ``dlo_env`` environment with vectorised
environments, and writes into its output folder: the model (``model.zip``), its
hyperparameters and the command-line-relevant settings (``hyperparameters.json``), the
``Monitor`` logs (``monitor/*.monitor.csv``, with ``is_success``) and a learning-curve PNG.
``load_baseline`` loads such a folder back as an object with ``predict``, which the evaluation
harness drives like any planner policy.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import asdict, dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import Any

import gymnasium as gym

ALGOS = ("ppo", "sac", "sac-her")
FORMAT_VERSION = 1


@dataclass(frozen=True)
class BaselineConfig:
    """A baseline run; defaults are the settings of the published numbers.

    Attributes:
        algo: ``"ppo"``, ``"sac"`` or ``"sac-her"``.
        env_id: Gymnasium id of the environment.
        difficulty: Task difficulty the agent trains on (``reset`` option).
        timesteps: Environment steps of training (summed over environments).
        n_envs: Parallel environments (``SubprocVecEnv`` when > 1).
        seed: Seed of the agent and the environments.
        net_arch: Hidden layer sizes of actor and critic networks.
        learning_rate: Adam step size.
        gamma: Discount factor (episodes are 100 steps).
        ppo_n_steps: PPO rollout length per environment.
        ppo_batch_size: PPO minibatch size.
        ppo_epochs: PPO epochs per rollout.
        sac_buffer_size: Replay buffer capacity (transitions).
        sac_batch_size: SAC minibatch size.
        sac_learning_starts: Random steps before SAC starts learning.
        her_n_sampled_goal: Relabelled goals per real transition (HER).
    """

    algo: str = "ppo"
    env_id: str = "dlo_env/DLOEndpoint-v0"
    difficulty: int = 1
    timesteps: int = 200_000
    n_envs: int = 4
    seed: int = 0
    net_arch: tuple[int, ...] = (256, 256)
    learning_rate: float = 3e-4
    gamma: float = 0.98
    ppo_n_steps: int = 512
    ppo_batch_size: int = 256
    ppo_epochs: int = 10
    sac_buffer_size: int = 300_000
    sac_batch_size: int = 256
    sac_learning_starts: int = 2_000
    her_n_sampled_goal: int = 4
    env_kwargs: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.algo not in ALGOS:
            raise ValueError(f"algo must be one of {ALGOS}, got {self.algo!r}")
        if self.timesteps < 1 or self.n_envs < 1:
            raise ValueError(
                f"timesteps and n_envs must be >= 1, got {self.timesteps} and {self.n_envs}"
            )
        if not 1 <= self.difficulty <= 5:
            raise ValueError(f"difficulty must be in 1..5, got {self.difficulty}")


class FixedDifficulty(gym.Wrapper):
    """Passes ``options={"difficulty": d}`` to every reset that gives no options."""

    def __init__(self, env: gym.Env, difficulty: int) -> None:
        super().__init__(env)
        self.difficulty = difficulty

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        return self.env.reset(seed=seed, options=options or {"difficulty": self.difficulty})


def _make_env(config: BaselineConfig, rank: int, monitor_dir: str | None) -> gym.Env:
    # Module-level so SubprocVecEnv can pickle it (via functools.partial).
    from stable_baselines3.common.monitor import Monitor

    import dlo_env  # noqa: F401  (registers the environments in the worker process)

    env = FixedDifficulty(gym.make(config.env_id, **config.env_kwargs), config.difficulty)
    path = None if monitor_dir is None else os.path.join(monitor_dir, str(rank))
    return Monitor(env, path, info_keywords=("is_success",))


def make_vec_env(config: BaselineConfig, monitor_dir: str | None = None) -> Any:
    """The vectorised training environment of ``config`` (subprocesses when ``n_envs > 1``)."""
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    factories = [partial(_make_env, config, i, monitor_dir) for i in range(config.n_envs)]
    vec = SubprocVecEnv(factories) if config.n_envs > 1 else DummyVecEnv(factories)
    vec.seed(config.seed)
    return vec


def build_model(config: BaselineConfig, env: Any, device: str = "auto") -> Any:
    """The untrained SB3 model of ``config`` on ``env``."""
    from stable_baselines3 import PPO, SAC, HerReplayBuffer

    policy_kwargs = {"net_arch": list(config.net_arch)}
    common = dict(
        policy="MultiInputPolicy", env=env, learning_rate=config.learning_rate,
        gamma=config.gamma, seed=config.seed, device=device, verbose=0,
        policy_kwargs=policy_kwargs,
    )
    if config.algo == "ppo":
        return PPO(
            n_steps=config.ppo_n_steps, batch_size=config.ppo_batch_size,
            n_epochs=config.ppo_epochs, **common,
        )
    extra: dict[str, Any] = {}
    if config.algo == "sac-her":
        extra = dict(
            replay_buffer_class=HerReplayBuffer,
            replay_buffer_kwargs=dict(
                n_sampled_goal=config.her_n_sampled_goal, goal_selection_strategy="future"
            ),
        )
    return SAC(
        buffer_size=config.sac_buffer_size, batch_size=config.sac_batch_size,
        learning_starts=config.sac_learning_starts, tau=0.005, train_freq=1,
        gradient_steps=1, **extra, **common,
    )


def _atomic_json(path: Path, data: dict[str, Any]) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(data, indent=2))
    os.replace(tmp, path)


def train_baseline(
    config: BaselineConfig, out_dir: str | os.PathLike, device: str = "auto",
    progress_bar: bool = True,
) -> Path:
    """Train the baseline of ``config`` and write model, hyperparameters, logs and curve.

    Returns:
        The path of the saved model (``out_dir/model.zip``).
    """
    out = Path(out_dir)
    monitor_dir = out / "monitor"
    monitor_dir.mkdir(parents=True, exist_ok=True)
    env = make_vec_env(config, str(monitor_dir))
    try:
        model = build_model(config, env, device=device)
        t0 = time.perf_counter()
        model.learn(total_timesteps=config.timesteps, progress_bar=progress_bar)
        seconds = time.perf_counter() - t0
        tmp = out / "model.tmp.zip"
        model.save(tmp)
        os.replace(tmp, out / "model.zip")
    finally:
        env.close()
    _atomic_json(
        out / "hyperparameters.json",
        {"format_version": FORMAT_VERSION, "config": asdict(config),
         "trained_timesteps": int(model.num_timesteps), "train_seconds": seconds},
    )
    plot_learning_curve(monitor_dir, out / "learning_curve.png", title=config.algo)
    return out / "model.zip"


def read_monitor_logs(monitor_dir: str | os.PathLike) -> dict[str, Any]:
    """Episodes of all ``*.monitor.csv`` files, ordered by wall time.

    Returns:
        Arrays ``reward``, ``length``, ``is_success`` and ``timesteps`` (cumulative steps).
    """
    import numpy as np

    rows = []
    for path in sorted(Path(monitor_dir).glob("*.monitor.csv")):
        lines = path.read_text().splitlines()
        header = lines[1].split(",")
        for line in lines[2:]:
            rows.append(dict(zip(header, line.split(","))))
    rows.sort(key=lambda r: float(r["t"]))
    length = np.array([int(r["l"]) for r in rows], dtype=np.int64)
    return {
        "reward": np.array([float(r["r"]) for r in rows]),
        "length": length,
        "is_success": np.array([r.get("is_success") == "True" for r in rows], dtype=float),
        "timesteps": np.cumsum(length),
    }


def plot_learning_curve(monitor_dir: str | os.PathLike, png: str | os.PathLike,
                        title: str = "") -> None:
    """Episode return and success rate (moving averages) against environment steps."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    logs = read_monitor_logs(monitor_dir)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 3.2))
    if len(logs["reward"]):
        k = max(1, len(logs["reward"]) // 50)
        kernel = np.ones(k) / k
        steps = logs["timesteps"][k - 1:]
        ax1.plot(steps, np.convolve(logs["reward"], kernel, mode="valid"))
        ax2.plot(steps, np.convolve(logs["is_success"], kernel, mode="valid"))
    ax1.set(xlabel="environment steps", ylabel="episode return", title=f"{title} return")
    ax2.set(xlabel="environment steps", ylabel="success rate", ylim=(0, 1),
            title=f"{title} success")
    fig.tight_layout()
    tmp = Path(str(png) + ".tmp.png")
    fig.savefig(tmp, dpi=100)
    plt.close(fig)
    os.replace(tmp, png)


def load_baseline(path: str | os.PathLike, device: str = "auto") -> Any:
    """Load a folder written by ``train_baseline`` (or its ``model.zip``).

    Returns:
        The SB3 model; it has ``predict(obs, state, episode_start, deterministic)``.
    """
    from stable_baselines3 import PPO, SAC

    p = Path(path)
    folder = p.parent if p.suffix == ".zip" else p
    meta_path = folder / "hyperparameters.json"
    if not meta_path.is_file():
        raise FileNotFoundError(
            f"path must be a baseline folder with hyperparameters.json, got {str(path)!r}"
        )
    meta = json.loads(meta_path.read_text())
    if meta.get("format_version") != FORMAT_VERSION:
        raise ValueError(
            f"{meta_path} has format_version {meta.get('format_version')!r}, "
            f"expected {FORMAT_VERSION}"
        )
    cfg = meta["config"]
    config = replace(BaselineConfig(), **{**cfg, "net_arch": tuple(cfg["net_arch"])})
    model_path = folder / "model.zip"
    if config.algo == "ppo":
        return PPO.load(model_path, device=device)
    # HER needs an env to rebuild its buffer; a single in-process env is enough to act.
    env = make_vec_env(replace(config, n_envs=1))
    return SAC.load(model_path, env=env, device=device)
