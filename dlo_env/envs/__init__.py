"""The goal-conditioned cord environments, one per module."""

from __future__ import annotations

from dlo_env.envs.dual_endpoint import DLODualEndpointEnv
from dlo_env.envs.endpoint import DLOEndpointEnv
from dlo_env.envs.goal_env import CordGoalEnv

#: Environment id -> (grasp of its tasks, its short name in dataset ids and result files).
ENVIRONMENTS = {
    "dlo_env/DLOEndpoint-v0": ("head", "endpoint"),
    "dlo_env/DLODualEndpoint-v0": ("both", "dual-endpoint"),
}

__all__ = ["ENVIRONMENTS", "CordGoalEnv", "DLODualEndpointEnv", "DLOEndpointEnv"]
