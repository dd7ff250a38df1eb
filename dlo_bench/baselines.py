"""Model-free RL baselines with Stable-Baselines3: PPO, SAC and SAC + HER.

``train_baseline`` trains one of them on a ``dlo_env`` environment with vectorised
environments, and writes into its output folder: the model (``model.zip``), its acting
weights (``policy.pt``, :mod:`dlo_bench.policy_file`), its hyperparameters
(``hyperparameters.json``), the ``Monitor`` logs (``monitor/*.monitor.csv``, with
``is_success``) and a learning-curve PNG. A checkpoint (``checkpoint.zip``) is written
atomically every ``checkpoint_every`` steps, so an interrupted run resumes (``resume=True``).
``load_baseline`` loads such a folder back as an object with ``predict``, which the evaluation
harness drives like any planner policy. The shipped baselines are in ``dlo_bench/pretrained/``:
``policy.pt`` and the run's hyperparameters, logs and curve (``model.zip`` is left out; the
agent's training command rebuilds it).
"""

from __future__ import annotations

import json
import math
import os
import time
from dataclasses import asdict, dataclass, fields, replace
from functools import partial
from numbers import Real
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from dlo_bench.policy_file import POLICY_FILE, load_policy_file, write_policy_file
from dlo_env.core.atomic import atomic_path, write_text_atomic
from dlo_env.core.checks import (
    check_fields,
    fractions,
    non_negative,
    non_negative_ints,
    positive,
    positive_ints,
)
from dlo_env.errors import InputError, MissingFileError

ALGOS = ("ppo", "sac", "sac-her")
#: The cords a baseline trains on (``BaselineConfig.cords``).
CORDS = ("fixed", "train")
#: The spawn key of ``RandomCords``' random stream.
CORDS_STREAM = 7
FORMAT_VERSION = 1
#: Episode length of the registered ``dlo_env`` environments (their ``max_episode_steps``).
EPISODE_STEPS = 100


@dataclass(frozen=True)
class BaselineConfig:
    """A baseline run; defaults are the settings of the published numbers.

    Attributes:
        algo: ``"ppo"``, ``"sac"`` or ``"sac-her"``.
        env_id: Gymnasium id of the environment.
        difficulties: Task difficulties the agent trains on; every episode draws one uniformly
            (the benchmark tests on 1, 2 and 3).
        reward_type: The environment's reward, ``"dense"`` (``-error``) or ``"sparse"``.
        timesteps: Environment steps of training (summed over environments).
        n_envs: Parallel environments.
        subprocess: Step the environments in subprocesses (``SubprocVecEnv``) instead of in
            turn in this process; only worth it with a free core per environment.
        seed: Seed of the agent and the environments.
        net_arch: Hidden layer sizes of the actor and critic networks.
        learning_rate: Adam step size.
        gamma: Discount factor (episodes are at most 100 steps).
        ppo_n_steps: PPO rollout length per environment.
        ppo_batch_size: PPO minibatch size.
        ppo_epochs: PPO epochs per rollout.
        ppo_gae_lambda: PPO's GAE lambda.
        ppo_ent_coef: PPO's entropy bonus.
        ppo_log_std_init: Initial log standard deviation of PPO's Gaussian actions.
        sac_buffer_size: Replay buffer capacity (transitions).
        sac_batch_size: SAC minibatch size.
        sac_learning_starts: Random steps before SAC starts learning (with HER it must exceed
            ``n_envs * 100`` so that whole episodes are stored first).
        sac_gradient_steps: Gradient steps per environment step of every environment.
        her_n_sampled_goal: Relabelled goals per real transition (HER, strategy "future").
        checkpoint_every: Environment steps between checkpoints (0: none).
        cords: ``"fixed"``: every episode on the environment's cord; ``"train"``: every
            episode on a cord drawn from ``dlo_env.randomize.DEFAULT_RANGES`` away from the
            held-out test cords (``draw_train_cord``), which the policy is not told.
        max_pegs: The environment's ``max_pegs``: every episode places 0 to ``max_pegs``
            pegs near its start, observed in ``max_pegs`` slots (0: the empty table).
        success_threshold: The training environment's success threshold, metres: episodes
            end, and the sparse reward is 0, within it (the benchmark then scores the agent
            at 2, 1 and 0.5 cm).
        surrogate: Train in ``env_id``'s learned twin (``dlo_env.SURROGATE_OF``): ``n_envs``
            cords stepped in one batched call of the transition model; every training step
            is then a surrogate step, none a pymunk one. The agent acts in ``env_id``.
        uncertainty_penalty: With ``surrogate``, the reward is lowered by this times the
            ensemble's spread of each prediction (metres; MOPO's penalty; 0: none).
    """

    algo: str = "ppo"
    env_id: str = "dlo_env/DLOEndpoint-v0"
    difficulties: tuple[int, ...] = (1, 2, 3)
    reward_type: str = "dense"
    timesteps: int = 300_000
    n_envs: int = 2
    subprocess: bool = False
    seed: int = 0
    net_arch: tuple[int, ...] = (256, 256)
    learning_rate: float = 3e-4
    gamma: float = 0.98
    ppo_n_steps: int = 1024
    ppo_batch_size: int = 256
    ppo_epochs: int = 10
    ppo_gae_lambda: float = 0.95
    ppo_ent_coef: float = 0.0
    ppo_log_std_init: float = -0.5
    sac_buffer_size: int = 300_000
    sac_batch_size: int = 256
    sac_learning_starts: int = 1_000
    sac_gradient_steps: int = 1
    her_n_sampled_goal: int = 4
    checkpoint_every: int = 20_000
    cords: str = "fixed"
    max_pegs: int = 0
    success_threshold: float = 0.02
    surrogate: bool = False
    uncertainty_penalty: float = 0.0

    def __post_init__(self) -> None:
        from dlo_env.cord import MAX_PEGS

        if not (isinstance(self.max_pegs, int) and not isinstance(self.max_pegs, bool)
                and 0 <= self.max_pegs <= MAX_PEGS):
            raise InputError(f"max_pegs must be an int from 0 to {MAX_PEGS}, "
                             f"got {self.max_pegs!r}", field="max_pegs")
        if self.algo not in ALGOS:
            raise InputError(f"algo must be one of {ALGOS}, got {self.algo!r}", field="algo")
        if self.cords not in CORDS:
            raise InputError(f"cords must be one of {CORDS}, got {self.cords!r}", field="cords")
        positive_ints(self, "timesteps", "n_envs", "ppo_n_steps", "ppo_batch_size",
                      "ppo_epochs", "sac_buffer_size", "sac_batch_size", "sac_gradient_steps",
                      "her_n_sampled_goal")
        non_negative_ints(self, "seed", "sac_learning_starts", "checkpoint_every")
        positive(self, "learning_rate", "success_threshold")
        check_fields(self, ("surrogate", "subprocess"), lambda v: isinstance(v, bool),
                     "True or False")
        non_negative(self, "uncertainty_penalty")
        if self.uncertainty_penalty and not self.surrogate:
            raise InputError("uncertainty_penalty needs surrogate=True (the pymunk environment "
                             "has no ensemble)", field="uncertainty_penalty")
        if self.surrogate and (self.cords != "fixed" or self.max_pegs or self.subprocess):
            raise InputError("surrogate needs cords='fixed', max_pegs=0 and subprocess=False: "
                             "the surrogate steps the empty table's default cord in one "
                             "process", field="surrogate")
        fractions(self, "gamma")
        fractions(self, "ppo_gae_lambda", closed_low=True)
        non_negative(self, "ppo_ent_coef")
        check_fields(self, ("learning_rate", "ppo_ent_coef", "ppo_log_std_init"),
                     lambda v: isinstance(v, Real) and not isinstance(v, bool)
                     and math.isfinite(v), "a finite number")
        check_fields(self, ("net_arch",), lambda v: isinstance(v, (tuple, list)) and all(
            isinstance(n, int) and not isinstance(n, bool) and n >= 1 for n in v),
            "a list of layer sizes >= 1 (e.g. [256, 256]; [] for none)")
        if not self.difficulties or not all(1 <= d <= 5 for d in self.difficulties):
            raise InputError(f"difficulties must be a non-empty tuple of ints in 1..5, "
                             f"got {self.difficulties!r}", field="difficulties")
        if self.reward_type not in ("dense", "sparse"):
            raise InputError(f"reward_type must be 'dense' or 'sparse', got {self.reward_type!r}",
                             field="reward_type")
        if self.algo == "sac-her" and self.sac_learning_starts <= self.n_envs * EPISODE_STEPS:
            # HER samples goals from finished episodes: learning cannot start before one ends.
            raise InputError(
                f"sac_learning_starts must exceed n_envs * {EPISODE_STEPS} = "
                f"{self.n_envs * EPISODE_STEPS} for sac-her, got {self.sac_learning_starts}",
                field="sac_learning_starts",
            )

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> BaselineConfig:
        """The config of a ``hyperparameters.json`` (lists back to tuples; unknown keys fail)."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise InputError(f"config has unknown keys {unknown}")
        values = {k: tuple(v) if isinstance(v, list) else v for k, v in data.items()}
        return replace(cls(), **values)


class ResumeMismatch(InputError):
    """A resumed run was given another config than the interrupted one."""


class RandomCords(gym.Wrapper):
    """Adds ``options["params"]``, a cord drawn by ``draw_train_cord``, to every reset that
    names none (a reset seed reseeds the draw, so runs repeat exactly)."""

    def __init__(self, env: gym.Env, seed: int = 0) -> None:
        super().__init__(env)
        self._rng = self._stream(seed)

    @staticmethod
    def _stream(seed: int) -> np.random.Generator:
        """The cords' own stream for ``seed``: not the one the environment and
        ``RandomDifficulty`` draw from with the same seed."""
        return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(CORDS_STREAM,)))

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Reset on a drawn cord unless ``options`` names one."""
        from dlo_env.randomize import draw_train_cord

        if seed is not None:
            self._rng = self._stream(seed)
        options = dict(options or {})
        if "params" not in options:
            options["params"] = draw_train_cord(self.env.unwrapped.params, self._rng)
        return self.env.reset(seed=seed, options=options)


class RandomDifficulty(gym.Wrapper):
    """Passes ``options={"difficulty": d}``, ``d`` drawn from ``difficulties``, to every reset
    that gives no options (a reset seed reseeds the draw, so runs repeat exactly)."""

    def __init__(self, env: gym.Env, difficulties: tuple[int, ...], seed: int = 0) -> None:
        super().__init__(env)
        self.difficulties = tuple(difficulties)
        self._rng = np.random.default_rng(seed)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Reset with a drawn difficulty unless ``options`` are given."""
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        if not options:
            options = {"difficulty": int(self._rng.choice(self.difficulties))}
        return self.env.reset(seed=seed, options=options)


def _make_env(config: BaselineConfig, rank: int, monitor_dir: str | None,
              append: bool = False) -> gym.Env:
    # Module-level so SubprocVecEnv can pickle it (via functools.partial).
    from stable_baselines3.common.monitor import Monitor

    import dlo_env  # noqa: F401  (registers the environments in the worker process)

    env = gym.make(config.env_id, reward_type=config.reward_type, max_pegs=config.max_pegs,
                   success_threshold=config.success_threshold)
    if config.cords == "train":
        env = RandomCords(env, seed=config.seed + 1000 * rank)
    env = RandomDifficulty(env, config.difficulties, seed=config.seed + 1000 * rank)
    path = None if monitor_dir is None else os.path.join(monitor_dir, str(rank))
    return Monitor(env, path, info_keywords=("is_success",), override_existing=not append)


def make_vec_env(config: BaselineConfig, monitor_dir: str | None = None,
                 append: bool = False) -> Any:
    """The vectorised training environment of ``config``.

    Args:
        config: The run.
        monitor_dir: Folder of the Monitor CSV files (none written if None).
        append: Append to existing Monitor files (a resumed run) instead of replacing them.
    """
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    if config.surrogate:
        return _surrogate_vec_env(config, monitor_dir, append)
    factories = [partial(_make_env, config, i, monitor_dir, append)
                 for i in range(config.n_envs)]
    vec = SubprocVecEnv(factories) if config.subprocess else DummyVecEnv(factories)
    vec.seed(config.seed)
    return vec


def _surrogate_vec_env(config: BaselineConfig, monitor_dir: str | None, append: bool) -> Any:
    """``config.n_envs`` learned cords as one SB3 ``VecEnv`` (``SB3VecEnv``), monitored."""
    from stable_baselines3.common.vec_env import VecMonitor

    from dlo_bench.sb3_vec_env import SB3VecEnv
    from dlo_env import SURROGATE_OF

    if config.env_id not in SURROGATE_OF:
        raise InputError(f"surrogate: {config.env_id!r} has no learned twin; one of "
                         f"{tuple(SURROGATE_OF)}")
    venv = gym.make_vec(SURROGATE_OF[config.env_id], num_envs=config.n_envs,
                        vectorization_mode="vector_entry_point", autoreset_mode="same_step",
                        reward_type=config.reward_type, difficulty=tuple(config.difficulties),
                        success_threshold=config.success_threshold,
                        uncertainty_penalty=config.uncertainty_penalty, device="cpu")
    path = None if monitor_dir is None else os.path.join(monitor_dir, "0")
    if path is not None and append:  # VecMonitor has no append: keep the earlier episodes
        old = Path(path + ".monitor.csv")
        if old.is_file():
            old.replace(old.with_name(f"{time.time_ns()}.monitor.csv"))
    vec = VecMonitor(SB3VecEnv(venv), path, info_keywords=("is_success",))
    vec.seed(config.seed)
    return vec


def build_model(config: BaselineConfig, env: Any, device: str = "cpu") -> Any:
    """The untrained SB3 model of ``config`` on ``env``."""
    from stable_baselines3 import PPO, SAC, HerReplayBuffer

    common = dict(
        policy="MultiInputPolicy", env=env, learning_rate=config.learning_rate,
        gamma=config.gamma, seed=config.seed, device=device, verbose=0,
    )
    if config.algo == "ppo":
        return PPO(
            n_steps=config.ppo_n_steps, batch_size=config.ppo_batch_size,
            n_epochs=config.ppo_epochs, gae_lambda=config.ppo_gae_lambda,
            ent_coef=config.ppo_ent_coef,
            policy_kwargs={"net_arch": list(config.net_arch),
                           "log_std_init": config.ppo_log_std_init},
            **common,
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
        gradient_steps=config.sac_gradient_steps,
        policy_kwargs={"net_arch": list(config.net_arch)}, **extra, **common,
    )


def _atomic_json(path: Path, data: dict[str, Any]) -> None:
    write_text_atomic(path, json.dumps(data, indent=2) + "\n")


def _save_atomic(model: Any, path: Path) -> None:
    with atomic_path(path) as tmp:  # the temporary name ends in .zip, as SB3 wants
        model.save(tmp)


def _training_callback(total: int, start: int, checkpoint: Path | None, every: int,
                       monitor_dir: Path, progress_bar: bool) -> Any:
    """A callback: tqdm progress, an atomic checkpoint and a log line every ``every`` steps."""
    from stable_baselines3.common.callbacks import BaseCallback

    class _Progress(BaseCallback):
        def _on_training_start(self) -> None:
            from dlo_env.core.progress import progress_bar as bar

            self._bar = bar(total, "training", "step", initial=start, enabled=progress_bar)
            self._next = (start // every + 1) * every if every else None
            self._t0, self._n0 = time.perf_counter(), start

        def _on_step(self) -> bool:
            self._bar.update(self.training_env.num_envs)
            if self._next is not None and self.num_timesteps >= self._next:
                self._next += every
                if checkpoint is not None:
                    _save_atomic(self.model, checkpoint)
                rate = (self.num_timesteps - self._n0) / (time.perf_counter() - self._t0)
                logs = read_monitor_logs(monitor_dir)
                recent = logs["is_success"][-100:]
                success = (f"success of the last {recent.size} episodes "
                           f"{float(recent.mean()):.2f}" if recent.size else "no episode ended yet")
                self._bar.write(f"step {self.num_timesteps}: {rate:.0f} steps/s, {success}")
            return True

        def _on_training_end(self) -> None:
            self._bar.close()

    return _Progress()


def check_out_folder(out: str | os.PathLike, resume: bool, name: str = "out") -> bool:
    """Whether training into ``out`` resumes a run (``resume`` and a ``checkpoint.zip``).

    Raises:
        ValueError: Naming ``name``, when ``out`` holds a finished run (``model.zip``, which
            training would replace), or an interrupted one and ``resume`` is False.
    """
    out = Path(out)
    interrupted = (out / "checkpoint.zip").is_file()
    if interrupted and not resume:
        raise InputError(f"{name} {str(out)!r} holds an interrupted run (checkpoint.zip): "
                         "resume it (--resume, resume=True) or choose another folder")
    if (out / "model.zip").is_file() and not interrupted:
        raise InputError(f"{name} {str(out)!r} holds a finished run (model.zip), which "
                         "training would replace: choose another folder")
    return resume and interrupted


def train_baseline(
    config: BaselineConfig, out_dir: str | os.PathLike, device: str = "cpu",
    progress_bar: bool = True, resume: bool = False, threads: int | None = 1,
) -> Path:
    """Train the baseline of ``config`` and write model, hyperparameters, logs and curve.

    Args:
        config: The run.
        out_dir: Output folder (created).
        device: Torch device.
        progress_bar: Show a tqdm bar (log lines every checkpoint either way).
        resume: Continue from ``out_dir/checkpoint.zip`` if it exists (same config required,
            except ``timesteps``); without one, train from the start.
            PPO resumes where it stopped; SAC resumes its networks with an empty replay buffer
            refilled by ``sac_learning_starts`` random steps.
        threads: ``torch.set_num_threads`` (None leaves it alone).

    Returns:
        The path of the saved model (``out_dir/model.zip``).

    Raises:
        ResumeMismatch: If resuming with another config than the interrupted run's.
        ValueError: If ``out_dir`` holds a finished run (``model.zip``), or an interrupted
            one and ``resume`` is False: nothing written is replaced.
    """
    import torch
    from stable_baselines3 import PPO, SAC
    from stable_baselines3.common.logger import Logger

    if threads is not None:
        torch.set_num_threads(threads)
    out = Path(out_dir)
    checkpoint = out / "checkpoint.zip"
    resuming = check_out_folder(out, resume)
    monitor_dir = out / "monitor"
    monitor_dir.mkdir(parents=True, exist_ok=True)
    if resuming:
        saved = BaselineConfig.from_dict(json.loads((out / "run.json").read_text())["config"])
        if replace(saved, timesteps=config.timesteps) != config:  # more steps are fine
            raise ResumeMismatch(f"resume needs the config of the interrupted run in "
                             f"{out}/run.json (only timesteps may change)")
    _atomic_json(out / "run.json", {"format_version": FORMAT_VERSION, "config": asdict(config)})
    env = make_vec_env(config, str(monitor_dir), append=resuming)
    try:
        if resuming:
            cls = PPO if config.algo == "ppo" else SAC
            model = cls.load(checkpoint, env=env, device=device)
            if config.algo != "ppo":
                model.learning_starts = model.num_timesteps + config.sac_learning_starts
        else:
            model = build_model(config, env, device=device)
        # SB3's default logger makes an empty SB3-<time> folder in the temp dir on every learn()
        model.set_logger(Logger(folder=None, output_formats=[]))
        start = int(model.num_timesteps)
        callback = _training_callback(
            config.timesteps, start, checkpoint if config.checkpoint_every else None,
            config.checkpoint_every, monitor_dir, progress_bar,
        )
        t0 = time.perf_counter()
        model.learn(total_timesteps=max(0, config.timesteps - start), callback=callback,
                    reset_num_timesteps=not resuming)
        seconds = time.perf_counter() - t0
        _save_atomic(model, out / "model.zip")
        write_policy_file(model, out / POLICY_FILE)
    finally:
        env.close()
    previous = 0.0
    meta_path = out / "hyperparameters.json"
    if resuming and meta_path.is_file():
        previous = float(json.loads(meta_path.read_text()).get("train_seconds", 0.0))
    _atomic_json(
        meta_path,
        {"format_version": FORMAT_VERSION, "config": asdict(config),
         "trained_timesteps": int(model.num_timesteps), "train_seconds": previous + seconds,
         # The sample cost by kind: pymunk steps, and learned-cord (surrogate) steps.
         "real_env_steps": 0 if config.surrogate else int(model.num_timesteps),
         "surrogate_steps": int(model.num_timesteps) if config.surrogate else 0,
         "resumed_at": start if resuming else None, "torch_threads": torch.get_num_threads()},
    )
    checkpoint.unlink(missing_ok=True)
    from dlo_bench.charts import plot_learning_curve

    plot_learning_curve(read_monitor_logs(monitor_dir), out / "learning_curve.png",
                        title=config.algo)
    return out / "model.zip"


def read_monitor_logs(monitor_dir: str | os.PathLike) -> dict[str, Any]:
    """Episodes of all ``*.monitor.csv`` files, ordered by wall time.

    Returns:
        Arrays ``reward``, ``length``, ``is_success`` and ``timesteps`` (cumulative steps).
    """
    rows = []
    for path in sorted(Path(monitor_dir).glob("*.monitor.csv")):
        lines = path.read_text().splitlines()
        if len(lines) < 2:
            continue
        header = lines[1].split(",")
        for line in lines[2:]:
            if line and not line.startswith("#") and not line.startswith("r,"):
                rows.append(dict(zip(header, line.split(","))))
    rows.sort(key=lambda r: float(r["t"]))
    length = np.array([int(r["l"]) for r in rows], dtype=np.int64)
    return {
        "reward": np.array([float(r["r"]) for r in rows]),
        "length": length,
        "is_success": np.array([r.get("is_success") == "True" for r in rows], dtype=float),
        "timesteps": np.cumsum(length),
    }


def read_baseline_metadata(path: str | os.PathLike) -> dict[str, Any]:
    """The ``hyperparameters.json`` of a baseline folder (or of the folder of a file in it).

    Raises:
        FileNotFoundError: If there is no such file.
        ValueError: If its format version is not this module's.
    """
    p = Path(path)
    folder = p.parent if p.is_file() else p
    meta_path = folder / "hyperparameters.json"
    if not meta_path.is_file() or not any((folder / f).is_file()
                                          for f in ("model.zip", POLICY_FILE)):
        raise MissingFileError(
            f"path must be a baseline folder with hyperparameters.json and model.zip or "
            f"{POLICY_FILE} (written by `dlo baseline`), got {str(path)!r}"
        )
    meta = json.loads(meta_path.read_text())
    if meta.get("format_version") != FORMAT_VERSION:
        raise InputError(
            f"{meta_path} has format_version {meta.get('format_version')!r}, "
            f"expected {FORMAT_VERSION}"
        )
    return meta


def load_baseline(path: str | os.PathLike, device: str = "cpu", algo: str = "",
                  cords: str = "") -> Any:
    """Load a folder written by ``train_baseline`` (or its ``model.zip``).

    Args:
        path: The folder (or its ``model.zip``).
        device: Torch device.
        algo: The algorithm the folder must hold ("" accepts any of ``ALGOS``).
        cords: The cords it must have trained on (``BaselineConfig.cords``; "" accepts any).

    Returns:
        The SB3 model; it has ``predict(obs, state, episode_start, deterministic)``.

    Raises:
        FileNotFoundError: If the folder holds no baseline.
        ValueError: If it holds another algorithm than ``algo``, was trained on other cords
            than ``cords``, or has another format version.
    """
    from stable_baselines3 import PPO, SAC

    p = Path(path)
    folder = p.parent if p.is_file() else p
    config = BaselineConfig.from_dict(read_baseline_metadata(folder)["config"])
    if algo and config.algo != algo:
        raise InputError(f"baseline {str(folder)!r} holds a {config.algo} model, not {algo}")
    if cords and config.cords != cords:
        raise InputError(f"baseline {str(folder)!r} was trained with --cords {config.cords}, "
                         f"not --cords {cords}")
    # One in-process env is enough to act (HER rebuilds its empty buffer around it).
    acting = replace(config, n_envs=1, subprocess=False, surrogate=False,
                     sac_learning_starts=10**9, sac_buffer_size=1,
                     ppo_n_steps=config.ppo_batch_size)  # (a rollout buffer of one batch)
    model_path = folder / "model.zip"
    if not model_path.is_file():  # the acting weights alone (what ships)
        return load_policy_file(build_model(acting, make_vec_env(acting), device=device),
                                folder / POLICY_FILE)
    if config.algo == "ppo":
        return PPO.load(model_path, device=device)
    return SAC.load(model_path, env=make_vec_env(acting), device=device, buffer_size=1)
