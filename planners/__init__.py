"""planners: the agents. Latent interpolation, the latent-tree planner, CEM over straight moves on
the simulator (physics-mpc) or on the learned transition model (latent-mpc), and the
straight-line reference, each an SB3-style policy.

The interfaces they share are ``typing.Protocol``s in :mod:`planners.interfaces`: the
``ShapeSurrogate`` a latent planner plans on, and the ``Policy`` / ``PlanningPolicy`` a harness
(``dlo_bench``) drives.
"""

from __future__ import annotations

from planners.adaptive_mpc import AdaptConfig, AdaptiveLatentMPCPolicy
from planners.cem import CEMConfig, CEMPolicy
from planners.interfaces import EpisodeStats, Plan, PlanningPolicy, Policy, ShapeSurrogate
from planners.interpolation import interpolate
from planners.latent_mpc import LatentMPCConfig, LatentMPCPolicy
from planners.latent_tree import LatentTreePlanner, TreeConfig
from planners.per_env import PerEnvPolicy
from planners.physics_mpc import PhysicsMPCConfig, PhysicsMPCPolicy
from planners.policy import PlannerPolicy
from planners.straight_line import StraightLinePolicy

__all__ = [
    "AdaptConfig",
    "AdaptiveLatentMPCPolicy",
    "CEMConfig",
    "CEMPolicy",
    "EpisodeStats",
    "LatentMPCConfig",
    "LatentMPCPolicy",
    "LatentTreePlanner",
    "PerEnvPolicy",
    "PhysicsMPCConfig",
    "PhysicsMPCPolicy",
    "Plan",
    "PlannerPolicy",
    "PlanningPolicy",
    "Policy",
    "ShapeSurrogate",
    "StraightLinePolicy",
    "TreeConfig",
    "interpolate",
]
