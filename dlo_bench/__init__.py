"""dlo_bench: the harness. Agents by name, evaluation against real rollouts, transition
fidelity, the benchmark, the Stable-Baselines3 baselines and the figures.

Every agent is run as a policy in the real simulator and scored on what the cord actually does
(``evaluate``); ``transition_fidelity`` compares a plan's predicted shapes with the real cord
doing the same end motion.
"""

from __future__ import annotations

from dlo_bench.agents import AGENTS, AgentOptions, AgentSpec, build_agent
from dlo_bench.evaluation import (
    EpisodeRecord,
    Evaluation,
    FidelityProfile,
    divergence,
    evaluate,
    summarise,
)
from dlo_bench.fidelity import Fidelity, transition_fidelity
from dlo_bench.report import format_divergence, format_table, write_evaluation, write_summaries

__all__ = [
    "AGENTS",
    "AgentOptions",
    "AgentSpec",
    "EpisodeRecord",
    "Evaluation",
    "Fidelity",
    "FidelityProfile",
    "build_agent",
    "divergence",
    "evaluate",
    "format_divergence",
    "format_table",
    "summarise",
    "transition_fidelity",
    "write_evaluation",
    "write_summaries",
]
