"""Deprecated location of :mod:`planners.episodic_policy` (the policy base class and how it
notices episodes), kept so that the names documented here in 0.2.0 still import."""

from __future__ import annotations

from planners.episodic_policy import (
    GOAL_TOLERANCE,
    GRIPPER_SLACK,
    JUMP_ERROR,
    EpisodicPolicy,
    gripper_reach,
)

__all__ = ["GOAL_TOLERANCE", "GRIPPER_SLACK", "JUMP_ERROR", "EpisodicPolicy", "gripper_reach"]
