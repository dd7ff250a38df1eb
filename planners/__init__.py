"""planners: latent interpolation, the latent-tree planner, planners as policies, evaluation.

Every planner is run as a policy in the real simulator and scored on what the cord actually
does (``evaluate``); ``transition_fidelity`` compares a plan's predicted shapes with the real
cord doing the same end motion.
"""

from __future__ import annotations

from planners.evaluation import (
    EpisodeRecord,
    Evaluation,
    FidelityProfile,
    divergence,
    evaluate,
    format_divergence,
    format_table,
)
from planners.fidelity import Fidelity, transition_fidelity
from planners.interpolation import interpolate
from planners.latent_tree import LatentTreePlanner, Plan, TreeConfig
from planners.policy import PlannerPolicy
from planners.straight_line import StraightLinePolicy

__all__ = [
    "EpisodeRecord",
    "Evaluation",
    "Fidelity",
    "FidelityProfile",
    "LatentTreePlanner",
    "Plan",
    "PlannerPolicy",
    "StraightLinePolicy",
    "TreeConfig",
    "divergence",
    "evaluate",
    "format_divergence",
    "format_table",
    "interpolate",
    "transition_fidelity",
]
