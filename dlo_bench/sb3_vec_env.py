"""A Gymnasium ``VectorEnv`` as a Stable-Baselines3 ``VecEnv``, without a process per env.

SB3 steps its own ``VecEnv`` interface (``step_async``/``step_wait``, a list of ``info``
dicts, the last observation of an ended episode in ``info["terminal_observation"]``), which a
batched Gymnasium vector environment does not offer. :class:`SB3VecEnv` adapts one that
autoresets in the same step (the surrogate environments with
``autoreset_mode="same_step"``), so PPO, SAC and HER train on thousands of learned cords
stepped in one call.

Example:
    >>> venv = gym.make_vec("dlo_env/DLOEndpointSurrogate-v0", num_envs=256,
    ...                     vectorization_mode="vector_entry_point", autoreset_mode="same_step")
    >>> model = stable_baselines3.PPO("MultiInputPolicy", SB3VecEnv(venv))
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices

from dlo_env.errors import InputError


class SB3VecEnv(VecEnv):
    """SB3's ``VecEnv`` over a Gymnasium ``VectorEnv`` with same-step autoreset.

    ``get_attr``, ``env_method`` and ``set_attr`` reach the vector environment itself (one
    object for all environments), so ``env_method("compute_reward", ...)``, which HER calls,
    computes a whole batch at once. Every ``info`` dict holds the vector environment's
    per-environment values and ``TimeLimit.truncated``; at an episode's end, those of its last
    step (``final_info``: ``is_success`` there is the episode's) and ``terminal_observation``.

    Args:
        venv: The vector environment, made with ``autoreset_mode="same_step"``.
    """

    def __init__(self, venv: gym.vector.VectorEnv) -> None:
        mode = getattr(venv, "metadata", {}).get("autoreset_mode")
        if mode != AutoresetMode.SAME_STEP:
            raise InputError(f"venv must autoreset in the same step (make it with "
                             f"autoreset_mode='same_step'), got {mode!r}")
        self.venv = venv
        self._actions: np.ndarray | None = None
        super().__init__(venv.num_envs, venv.single_observation_space,
                         venv.single_action_space)

    def reset(self) -> dict[str, np.ndarray]:
        """Reset every environment (with the seed given to ``seed()``, if any)."""
        seed = self._seeds[0]
        options = self._options[0] or None
        obs, info = self.venv.reset(seed=seed, options=options)
        self.reset_infos = self._split(info, np.zeros(self.num_envs, dtype=bool))
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        """Remember the actions; ``step_wait`` steps them."""
        self._actions = np.asarray(actions)

    def step_wait(self) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray, list[dict]]:
        """Step every environment: observations, rewards, dones and ``info`` dicts."""
        obs, reward, terminated, truncated, info = self.venv.step(self._actions)
        done = terminated | truncated
        infos = self._split(info, truncated & ~terminated)
        if done.any():  # SB3 wants the ending step's info there, not the new episode's
            ended = self._split(info["final_info"], truncated & ~terminated)
            final = info["final_obs"]
            for i in np.flatnonzero(done):
                infos[i] = {**ended[i], "terminal_observation": final[i]}
        return obs, reward.astype(np.float32), done, infos

    def _split(self, info: dict[str, Any], timeout: np.ndarray) -> list[dict[str, Any]]:
        """Per-environment dicts of the batched ``info`` (only the keys each env has)."""
        keys = [k for k in info if not k.startswith("_") and k not in ("final_obs",
                                                                         "final_info")]
        out: list[dict[str, Any]] = [{"TimeLimit.truncated": bool(t)} for t in timeout]
        for key in keys:
            value, mask = info[key], info.get(f"_{key}")
            for i in range(self.num_envs) if mask is None else np.flatnonzero(mask):
                out[i][key] = value[i]
        return out

    def close(self) -> None:
        """Close the vector environment."""
        self.venv.close()

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """The vector environment's attribute, once per index."""
        value = getattr(self.venv.unwrapped, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Set the vector environment's attribute (shared by every index)."""
        setattr(self.venv.unwrapped, attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None,
                   **method_kwargs: Any) -> list[Any]:
        """Call the vector environment's method once, the result repeated per index."""
        result = getattr(self.venv.unwrapped, method_name)(*method_args, **method_kwargs)
        return [result for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper],
                       indices: VecEnvIndices = None) -> list[bool]:
        """False: the batch is one object, not wrapped environments."""
        return [False for _ in self._get_indices(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        """One frame per environment, when the vector environment renders."""
        frames = self.venv.render()
        return list(frames) if frames is not None else [None] * self.num_envs
