"""Any Stable-Baselines3 model as an agent: ``sb3:PATH`` for a ``dlo baseline`` folder, a
plain ``model.zip`` or an rl-zoo3 run folder.

:func:`find_sb3` says what ``PATH`` holds without unpickling anything: the model file, its
algorithm (read from the zip's JSON ``data``), whether it learned with HER, and what is known
of its training (the environment, the success threshold episodes ended at). What a folder
does not record is ``None`` ("unknown" in messages); what it records is checked against the
model. :func:`load_sb3` then loads the model for an environment, whose spaces must be the
model's.
"""

from __future__ import annotations

import json
import os
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym

from dlo_bench.policy_file import POLICY_FILE, weights_file
from dlo_env.errors import InputError, MissingFileError

#: SB3 algorithm classes by the package path of their policies; on-policy models of
#: ``common.policies`` are PPO when they have a clip range, else A2C.
_ALGO_BY_MODULE = {"stable_baselines3.sac": "SAC", "stable_baselines3.td3": "TD3",
                   "sb3_contrib.tqc": "TQC"}


@dataclass(frozen=True)
class SB3Source:
    """What an ``sb3:PATH`` holds.

    Attributes:
        path: The path as given.
        model_file: The model's zip (a ``dlo baseline`` folder's ``policy.pt`` where it has
            no ``model.zip``, as the shipped ones).
        algo: The SB3 class name (``"PPO"``, ``"SAC"``, ``"TD3"``, ``"A2C"``, ``"TQC"``).
        her: It learned with a HER replay buffer (loading it needs an environment).
        kind: ``"dlo baseline"``, ``"rl-zoo3"`` or ``"model.zip"``.
        env_id: The environment it trained in (None: unknown).
        training_threshold: The success threshold its training episodes ended at, metres
            (None: unknown).
        config: The ``dlo baseline`` config, when there is one.
    """

    path: str
    model_file: Path
    algo: str
    her: bool
    kind: str
    env_id: str | None = None
    training_threshold: float | None = None
    config: dict[str, Any] | None = None

    def describe(self) -> str:
        """One line: what it is and what is known of its training."""
        env = self.env_id or "unknown"
        threshold = ("unknown" if self.training_threshold is None
                     else f"{100 * self.training_threshold:g} cm")
        return (f"{self.algo}{' + HER' if self.her else ''} ({self.kind}, {self.model_file}); "
                f"trained in {env}, episodes ending at {threshold}")


def _zip_facts(model_file: Path) -> tuple[str, bool]:
    """The algorithm and HER of an SB3 zip, from its JSON ``data`` (no unpickling)."""
    try:
        with zipfile.ZipFile(model_file) as archive:
            data = json.loads(archive.read("data"))
    except (OSError, zipfile.BadZipFile, KeyError, json.JSONDecodeError) as exc:
        raise InputError(f"{model_file} is not a Stable-Baselines3 model zip: {exc}") from None
    module = str(data.get("policy_class", {}).get("__module__", ""))
    her = "her" in str(data.get("replay_buffer_class", {}).get("__module__", ""))
    for prefix, algo in _ALGO_BY_MODULE.items():
        if module.startswith(prefix):
            return algo, her
    if module == "stable_baselines3.common.policies":
        return ("PPO" if "clip_range" in data else "A2C"), her
    raise InputError(f"{model_file}: a model of {module or 'an unknown policy'}, which sb3: "
                     f"does not load (PPO, A2C, SAC, TD3 and TQC do)")


def _read_zoo_yaml(path: Path) -> dict[str, Any]:
    """An rl-zoo3 ``args.yml`` or ``config.yml``: YAML dumps of ``OrderedDict`` s, read as
    plain dicts by a safe loader (no other Python object is built)."""
    import yaml

    class Loader(yaml.SafeLoader):
        pass

    def ordered(loader: yaml.SafeLoader, node: yaml.Node) -> dict[str, Any]:
        pairs = loader.construct_sequence(node.value[0], deep=True) if node.value else []
        return {k: v for k, v in pairs}

    Loader.add_constructor("tag:yaml.org,2002:python/object/apply:collections.OrderedDict",
                           ordered)
    data = yaml.load(path.read_text(), Loader=Loader)  # noqa: S506 (a safe loader)
    return data if isinstance(data, dict) else {}


def _zoo_facts(folder: Path) -> tuple[Path | None, str | None, float | None]:
    """An rl-zoo3 run folder's model (``best_model.zip``, else ``ENV.zip``), environment
    (``args.yml``) and training threshold (``env_kwargs`` of ``config.yml``; None when it
    leaves the environment's default)."""
    env_id = threshold = None
    normalised = sorted(folder.glob("*/vecnormalize.pkl"))
    if normalised:
        raise InputError(f"sb3:PATH: {folder} was trained on normalised observations "
                         f"({normalised[0].name}), which sb3: does not apply: train without "
                         "normalize, or wrap the model so its predict normalises")
    for args_file in sorted(folder.glob("*/args.yml"))[:1]:
        env_id = _read_zoo_yaml(args_file).get("env")
        config = args_file.with_name("config.yml")
        if config.is_file():
            kwargs = _read_zoo_yaml(config).get("env_kwargs") or {}
            threshold = kwargs.get("success_threshold") if isinstance(kwargs, dict) else None
    zips = [folder / "best_model.zip"] + sorted(folder.glob("*.zip"))
    model = next((z for z in zips if z.is_file()), None)
    return model, env_id, threshold


def find_sb3(path: str | os.PathLike) -> SB3Source:
    """What ``path`` holds: a ``dlo baseline`` folder (``model.zip`` and
    ``hyperparameters.json``), a folder with a ``model.zip`` alone, an rl-zoo3 run folder
    (``best_model.zip`` or ``ENV.zip``, and ``ENV/args.yml``), or a model zip itself.

    Raises:
        FileNotFoundError: When ``path`` holds no SB3 model.
        ValueError: When the zip is not an SB3 model, or a ``hyperparameters.json`` says
            another algorithm than the zip holds.
    """
    p = Path(path)
    if p.is_file():
        algo, her = _zip_facts(p)
        return SB3Source(str(path), p, algo, her, "model.zip")
    if not p.is_dir():
        raise MissingFileError(f"sb3:PATH must be an SB3 model.zip, a `dlo baseline` folder "
                                f"or an rl-zoo3 run folder, got {str(path)!r} (no such file)")
    meta = p / "hyperparameters.json"
    weights = weights_file(p)
    if weights.is_file() and meta.is_file():
        from dlo_bench.baselines import BaselineConfig, read_baseline_metadata

        config = read_baseline_metadata(p)["config"]
        said = BaselineConfig.from_dict(config).algo
        algo, her = said.split("-")[0].upper(), said == "sac-her"
        held = _zip_facts(weights) if weights.suffix == ".zip" else (algo, her)
        if held != (algo, her):
            algo, her = held
            raise InputError(f"{meta} says {said}, but model.zip holds a {algo}"
                             f"{' + HER' if her else ''} model")
        return SB3Source(str(path), weights, algo, her, "dlo baseline",
                         config.get("env_id"), config.get("success_threshold", 0.02), config)
    if (p / "model.zip").is_file():
        algo, her = _zip_facts(p / "model.zip")
        return SB3Source(str(path), p / "model.zip", algo, her, "model.zip")
    model, env_id, threshold = _zoo_facts(p)
    if model is None:
        raise MissingFileError(f"sb3:PATH: {str(path)!r} holds no model.zip, best_model.zip "
                                "or rl-zoo3 ENV.zip")
    algo, her = _zip_facts(model)
    return SB3Source(str(path), model, algo, her, "rl-zoo3", env_id, threshold)


def load_sb3(source: SB3Source, env: Any, device: str = "cpu") -> Any:
    """The model of ``source``, to act in ``env`` (a Gymnasium environment).

    Raises:
        ValueError: One line when the model's observation or action space is not ``env``'s
            (a model trained on flattened observations: see ``docs/benchmark.md``).
    """
    import stable_baselines3 as sb3

    if source.algo == "TQC":
        import sb3_contrib

        cls = sb3_contrib.TQC
    else:
        cls = getattr(sb3, source.algo)
    if source.model_file.name == POLICY_FILE:  # a dlo baseline folder's acting weights
        from dlo_bench.baselines import load_baseline

        model = load_baseline(source.model_file.parent, device=device)
        return _fitted(model, source, env)
    extra: dict[str, Any] = {}
    if source.her:  # HER rebuilds its (empty) buffer around an environment
        from stable_baselines3.common.vec_env import DummyVecEnv

        extra = {"env": DummyVecEnv([lambda: env]), "buffer_size": 1}
    return _fitted(cls.load(source.model_file, device=device, **extra), source, env)


def _fitted(model: Any, source: SB3Source, env: Any) -> Any:
    """``model`` acting in ``env``: as it is, or on flattened observations.

    Raises:
        ValueError: One line when its spaces are not ``env``'s.
    """
    if model.action_space != env.action_space:
        raise InputError(f"sb3:{source.path}: the model's action space is "
                         f"{model.action_space}, the environment's {env.action_space}")
    if model.observation_space == env.observation_space:
        return model
    if model.observation_space == gym.spaces.flatten_space(env.observation_space):
        return FlatObservationPolicy(model, env.observation_space)
    raise InputError(f"sb3:{source.path}: the model observes {model.observation_space}, "
                     f"neither the environment's Dict nor its flattened form")


class FlatObservationPolicy:
    """A policy trained on flattened observations (``gymnasium.wrappers.FlattenObservation``)
    acting on the environments' Dict observations: each observation, or a vector env's batch,
    is flattened as that wrapper flattens it (the Dict's keys in order) before ``predict``.

    Args:
        model: Anything with SB3's ``predict``, trained on flat observations.
        space: The environment's Dict observation space.
    """

    def __init__(self, model: Any, space: Any) -> None:
        self.model = model
        self.keys = list(space.spaces)
        self.space = space
        self.observation_space = gym.spaces.flatten_space(space)

    def flatten(self, obs: dict[str, Any]) -> Any:
        """``(size,)`` for one observation, ``(B, size)`` for a batch."""
        import numpy as np

        parts = [np.asarray(obs[k], dtype=np.float32) for k in self.keys]
        single = parts[0].ndim == len(self.space[self.keys[0]].shape)
        if single:
            return np.concatenate([p.reshape(-1) for p in parts])
        return np.concatenate([p.reshape(len(p), -1) for p in parts], axis=1)

    def predict(self, observation: dict[str, Any], state: Any = None,
                episode_start: Any = None, deterministic: bool = False) -> tuple[Any, Any]:
        """The model's action for the flattened observation."""
        return self.model.predict(self.flatten(observation), state, episode_start,
                                  deterministic)
