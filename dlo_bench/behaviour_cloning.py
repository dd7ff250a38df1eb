"""Behaviour cloning from the Minari oracle demonstrations: the ``bc`` agent.

The policy is Stable-Baselines3's own ``MultiInputPolicy`` (a PPO actor-critic, Gaussian
actions) trained by maximum likelihood of the demonstrated actions given the demonstrated Dict
observations (loss ``-log_prob - ent_weight * entropy``, as ``imitation``'s BC). ``imitation``
(pins Gymnasium 0.29 and SB3 2.2) and d3rlpy (pins Gymnasium 1.0.0) cannot be installed next to
this project's Gymnasium 1.4 and SB3 2.9, so the few lines of the loss live here; everything else
(networks, distributions, optimiser, saving, ``predict``) is SB3's, and the data is read with
Minari's own ``load_dataset``.

``train_bc`` writes a folder like ``dlo baseline`` does: ``model.zip`` (``PPO.load`` reads
it), ``policy.pt`` (the acting weights, what ships) and ``hyperparameters.json``, whose
``trained_timesteps`` is the sample cost: the environment steps of the demonstrations used (no
environment interaction happens during training).
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any

import numpy as np

from dlo_bench.policy_file import POLICY_FILE, load_policy_file, write_policy_file
from dlo_env.core.atomic import atomic_path, write_text_atomic
from dlo_env.errors import InputError, MissingFileError

FORMAT_VERSION = 1
#: The demonstrations a ``bc`` agent is cloned from, per environment: the oracle of the
#: train splits of linear-1 to linear-3 (``dlo export-minari --env ENV``).
DEMONSTRATIONS = {
    env_id: tuple(f"dlo/{label}/linear-{d}-oracle-v0" for d in (1, 2, 3))
    for env_id, label in (("dlo_env/DLOEndpoint-v0", "endpoint"),
                          ("dlo_env/DLODualEndpoint-v0", "dual-endpoint"))}
#: The demonstrations of the benchmark's difficulties in ``DLOEndpoint-v0``.
ENDPOINT_DEMONSTRATIONS = DEMONSTRATIONS["dlo_env/DLOEndpoint-v0"]


@dataclass(frozen=True)
class BCConfig:
    """A behaviour-cloning run; defaults are the settings of the published numbers.

    Attributes:
        datasets: Minari ids of the demonstrations (``dlo export-minari`` writes them), all of
            one environment.
        root: Minari dataset root (None: Minari's own).
        episodes_per_dataset: Use only the first episodes of each dataset (None: all).
        net_arch: Hidden layer sizes of the policy network.
        log_std_init: Initial log standard deviation of the Gaussian actions.
        learning_rate: Adam step size.
        batch_size: Minibatch size (demonstration steps).
        epochs: Passes over the demonstrations.
        ent_weight: Weight of the entropy bonus in the loss.
        seed: Seed of the network initialisation and the minibatch order.
    """

    datasets: tuple[str, ...] = ENDPOINT_DEMONSTRATIONS
    root: str | None = None
    episodes_per_dataset: int | None = None
    net_arch: tuple[int, ...] = (256, 256)
    log_std_init: float = -1.0
    learning_rate: float = 1e-3
    batch_size: int = 256
    epochs: int = 300
    ent_weight: float = 1e-3
    seed: int = 0

    def __post_init__(self) -> None:
        if not self.datasets:
            raise InputError("datasets must name at least one Minari dataset")
        for name in ("batch_size", "epochs"):
            if not (isinstance(getattr(self, name), int) and getattr(self, name) >= 1):
                raise InputError(f"{name} must be an int >= 1, got {getattr(self, name)!r}")

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> BCConfig:
        """The config of a ``hyperparameters.json`` (lists back to tuples; unknown keys fail)."""
        unknown = sorted(set(data) - {f.name for f in fields(cls)})
        if unknown:
            raise InputError(f"config has unknown keys {unknown}")
        return replace(cls(), **{k: tuple(v) if isinstance(v, list) else v
                                 for k, v in data.items()})


@dataclass(frozen=True)
class Demonstrations:
    """Demonstration steps: ``observations`` (Dict of ``(N, ...)``), ``actions`` ``(N, dim)``."""

    env_spec: Any
    observations: dict[str, np.ndarray]
    actions: np.ndarray
    episodes: int


def load_demonstrations(config: BCConfig) -> Demonstrations:
    """The (observation, action) pairs of ``config.datasets``, read with Minari.

    Raises:
        FileNotFoundError: When a dataset is missing (with the command that writes it).
        ValueError: When the datasets come from different environments.
    """
    import minari

    from dlo_env.dataset.minari_export import minari_root

    observations: dict[str, list[np.ndarray]] = {}
    actions, specs, episodes = [], set(), 0
    with minari_root(config.root):
        for dataset_id in config.datasets:
            try:
                dataset = minari.load_dataset(dataset_id)
            except FileNotFoundError as exc:
                raise MissingFileError(
                    f"no Minari dataset {dataset_id!r}; write it with `dlo export-minari`"
                    + (f" --root {config.root}" if config.root else "")) from exc
            env_spec = dataset.spec.env_spec
            specs.add(env_spec.id)
            limit = config.episodes_per_dataset or dataset.total_episodes
            for episode in dataset.iterate_episodes(range(min(limit, dataset.total_episodes))):
                for key, value in episode.observations.items():
                    observations.setdefault(key, []).append(value[:-1])  # obs before each action
                actions.append(episode.actions)
                episodes += 1
    if len(specs) != 1:
        raise InputError(f"datasets must all come from one environment, got {sorted(specs)}")
    return Demonstrations(env_spec, {k: np.concatenate(v) for k, v in observations.items()},
                          np.concatenate(actions).astype(np.float32), episodes)


def train_bc(config: BCConfig, out_dir: str | os.PathLike[str], threads: int | None = 1,
             progress: bool = False) -> Path:
    """Clone the demonstrations of ``config`` into an SB3 policy; returns ``out_dir/model.zip``.

    Args:
        config: The run.
        out_dir: Output folder (created); gets ``model.zip`` and ``hyperparameters.json``.
        threads: ``torch.set_num_threads`` (None leaves it alone).
        progress: Print the loss after every tenth of the epochs.
    """
    import gymnasium as gym
    import torch
    from stable_baselines3.common.utils import obs_as_tensor

    if threads is not None:
        torch.set_num_threads(threads)
    demos = load_demonstrations(config)
    env = gym.make(demos.env_spec)
    model = build_bc_model(config, env)
    policy = model.policy
    policy.set_training_mode(True)
    observations = obs_as_tensor(demos.observations, policy.device)
    actions = torch.as_tensor(demos.actions, device=policy.device)
    rng = np.random.default_rng(config.seed)
    started, n = time.perf_counter(), len(actions)
    for epoch in range(config.epochs):
        total = 0.0
        for batch in np.array_split(rng.permutation(n), max(1, n // config.batch_size)):
            index = torch.as_tensor(batch)
            _, log_prob, entropy = policy.evaluate_actions(
                {k: v[index] for k, v in observations.items()}, actions[index])
            loss = -log_prob.mean() - config.ent_weight * entropy.mean()
            policy.optimizer.zero_grad()
            loss.backward()
            policy.optimizer.step()
            total += float(loss.detach()) * len(batch)
        if progress and (epoch + 1) % max(1, config.epochs // 10) == 0:
            print(f"epoch {epoch + 1}/{config.epochs}: loss {total / n:.4f}", flush=True)
    policy.set_training_mode(False)
    env.close()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    with atomic_path(out / "model.zip") as tmp:  # the temporary name ends in .zip, as SB3 wants
        model.save(tmp)
    write_policy_file(model, out / POLICY_FILE)
    meta = {"format_version": FORMAT_VERSION, "algo": "bc", "config": asdict(config),
            "env_id": demos.env_spec.id, "trained_timesteps": n,
            "demonstration_episodes": demos.episodes, "environment_interaction_steps": 0,
            "train_seconds": time.perf_counter() - started,
            "torch_threads": torch.get_num_threads()}
    write_text_atomic(out / "hyperparameters.json", json.dumps(meta, indent=2) + "\n")
    return out / "model.zip"


def load_bc(path: str | os.PathLike[str], device: str = "cpu", env_id: str | None = None
            ) -> Any:
    """Load a folder written by ``train_bc`` (or its ``model.zip``): an SB3 model whose
    ``predict(obs, state, episode_start, deterministic)`` acts.

    Args:
        path: The folder or its ``model.zip``.
        device: Torch device.
        env_id: The environment it will act in: refused unless the demonstrations came from
            it (None: not checked).

    Raises:
        FileNotFoundError: If the folder holds no behaviour-cloning model.
        ValueError: If it holds another algorithm or another format version, or was cloned
            in another environment than ``env_id``.
    """
    from stable_baselines3 import PPO

    from dlo_bench.baselines import read_baseline_metadata

    p = Path(path)
    folder = p.parent if p.is_file() else p
    meta = read_baseline_metadata(folder)
    if meta.get("algo") != "bc":
        raise InputError(f"path {str(folder)!r} holds no behaviour-cloning model (algo "
                         f"{meta.get('algo', meta.get('config', {}).get('algo'))!r})")
    if env_id is not None and meta.get("env_id") != env_id:
        raise InputError(f"path {str(folder)!r} holds a policy cloned in {meta.get('env_id')}, "
                         f"not {env_id}")
    if not (folder / "model.zip").is_file():  # the acting weights alone (what ships)
        import gymnasium as gym

        with gym.make(meta["env_id"]) as env:
            model = build_bc_model(BCConfig.from_dict(meta["config"]), env, device)
        return load_policy_file(model, folder / POLICY_FILE)
    return PPO.load(folder / "model.zip", device=device)


def build_bc_model(config: BCConfig, env: Any, device: str = "cpu") -> Any:
    """The untrained SB3 model (PPO's policy) that ``config`` clones into, on ``env``."""
    from stable_baselines3 import PPO

    return PPO("MultiInputPolicy", env, seed=config.seed, device=device, verbose=0,
               learning_rate=config.learning_rate,
               policy_kwargs={"net_arch": list(config.net_arch),
                              "log_std_init": config.log_std_init})
