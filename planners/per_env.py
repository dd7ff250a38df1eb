"""One policy per environment of a vector env, for policies that act in one environment only.

Most policies take a batch (one plan per row; SB3 models natively). A policy tied to the
environment it was built from, such as ``physics-mpc-true-cord`` (it reads that environment's
cord), takes a batch of 1 and says so (``plans_batches = False``). :class:`PerEnvPolicy` gives
each environment of a vector env its own policy::

    envs = gym.vector.SyncVectorEnv([lambda: gym.make(ENV_ID)] * 2)
    policy = PerEnvPolicy([build_agent("physics-mpc-true-cord", e) for e in envs.envs])
    actions, _ = policy.predict(obs)          # row i planned by policy i
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from dlo_env.errors import InputError
from planners.episodic_policy import _starts
from planners.interfaces import Policy
from planners.observation import split_batch


class PerEnvPolicy:
    """SB3's ``predict`` over a batch whose row ``i`` is planned by ``policies[i]``.

    Args:
        policies: One policy per environment, in the vector env's order.
    """

    def __init__(self, policies: Sequence[Policy]) -> None:
        self.policies = list(policies)
        if not self.policies or not all(isinstance(p, Policy) for p in self.policies):
            kinds = ", ".join(sorted({type(p).__name__ for p in self.policies})) or "none"
            raise InputError("policies must be a non-empty list of policies with predict(), "
                             f"got {kinds}")

    def predict(self, observation: Any, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, Any]:
        """``(actions, state)``: ``(B, action_dim)`` for a batch of B = ``len(policies)`` (an
        unbatched observation is one environment: for a list of one policy)."""
        rows, batched = split_batch(observation)
        if len(rows) != len(self.policies):
            raise InputError(f"observation must hold one row per policy ({len(self.policies)}),"
                             f" got {len(rows)}")
        starts = _starts(episode_start, len(rows))
        actions = [np.asarray(policy.predict(row, None, starts[i:i + 1], deterministic)[0],
                              dtype=np.float32).reshape(-1)
                   for i, (policy, row) in enumerate(zip(self.policies, rows))]
        return (np.stack(actions) if batched else actions[0]), state

    def reset(self) -> None:
        """Forget every environment's episode."""
        for policy in self.policies:
            getattr(policy, "reset", lambda: None)()
