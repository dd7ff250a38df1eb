"""The goal-conditioned cord environments, one per module."""

from __future__ import annotations

from dlo_env.envs.dual_endpoint import DLODualEndpointEnv
from dlo_env.envs.endpoint import DLOEndpointEnv
from dlo_env.envs.goal_env import CordGoalEnv

__all__ = ["CordGoalEnv", "DLODualEndpointEnv", "DLOEndpointEnv"]
