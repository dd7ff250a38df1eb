"""The comparison benchmark: every agent on the test suites of both environments, one table.

``run_benchmark`` evaluates the registered agents (``dlo_bench.agents.AGENTS``) on the test
split of the suites ``linear-1`` to ``linear-5`` in ``DLOEndpoint-v0`` and ``linear-1`` to
``linear-3`` in ``DLODualEndpoint-v0``, and the long horizons ``linear-8`` and ``linear-10`` in
both (fixed tasks, so every agent sees the same episodes) with
:func:`dlo_bench.evaluation.evaluate`, once at each success threshold (2, 1 and 0.5 cm, judged
on the cord at rest; the planners take their stopping rules from it). The designed suites
(``shapes-curves``: drawn goals, scored direction-free) run once, at the headline threshold,
in every environment; their rows add the errors per curve family beside the reference errors
of :mod:`dlo_bench.reference`. The ``cords`` section runs the cord suites (``cords-3``: each
task on a held-out cord the agents are not told, :mod:`dlo_env.cord_suites`) with the agents
of ``CORD_AGENTS``, at the headline threshold. The ``pegs`` section runs the peg suites
(``pegs-K``: goals made by K moves among pegs; ``route-K``: goals that need the cord routed
around a peg, :mod:`dlo_env.peg_suites`) with the agents of ``PEG_AGENTS`` in an environment
that observes the pegs, at the headline threshold; its RL agents are those trained there
(``dlo baseline --max-pegs``). An agent that does not act
in an environment, or whose model is missing, gets a row that says so, never silently none.
Every row states the agent's sample cost: the data its model or policy was trained on. Every
finished (agent, environment, suite, threshold) cell is written at once, so an interrupted
run resumes; :func:`dlo_bench.benchmark_report.write_results` then writes the table (Markdown),
the rows (JSON) and a bar chart (PNG), all atomically.

Every cell records what made it: the git commit of the code (:func:`code_version`, ``+dirty``
with uncommitted changes to tracked files) and the run (one invocation, :func:`new_run_id`) that
timed it, so the report compares planning times only between cells of one run.

The package's modules, bottom to top: :mod:`~dlo_bench.benchmark.config` (what runs),
:mod:`~dlo_bench.benchmark.provenance` (what made a cell), :mod:`~dlo_bench.benchmark.cells`
(names, keys, parts, loading and merging), :mod:`~dlo_bench.benchmark.rows` (a cell's row in
the results) and :mod:`~dlo_bench.benchmark.run` (the run). Their public names import from
here.
"""

from __future__ import annotations

from dlo_bench.benchmark.cells import (
    CELLS_DIR,
    PARTS_DIR,
    agent_label,
    cell_key,
    cell_name,
    env_label,
    merge_parts,
    part_name,
    split_episodes,
    suite_label,
)
from dlo_bench.benchmark.config import (
    CORD_AGENTS,
    CORD_ENVS,
    DEFAULT_CORDS,
    DEFAULT_DESIGNED,
    DEFAULT_DIFFICULTIES,
    DEFAULT_PEGS,
    HEADLINE_THRESHOLD,
    PEG_AGENTS,
    PEG_ENVS,
    QUICK_DESIGNED_ENVS,
    QUICK_DIFFICULTIES,
    QUICK_EPISODES,
    QUICK_SECTIONS,
    SUITE_OF_DIFFICULTY,
    THRESHOLDS,
    BenchmarkConfig,
    absolute_paths,
    registered,
)
from dlo_bench.benchmark.provenance import (
    CODE_ROOT,
    RUN_FACTS,
    CodeState,
    code_state,
    code_version,
    machine_label,
    new_run_id,
)
from dlo_bench.benchmark.rows import (
    NEAR_REFERENCE,
    cords_summary,
    designed_summary,
    designed_tasks,
    peg_tasks,
    row_of,
)
from dlo_bench.benchmark.run import run_benchmark, run_cell
from dlo_bench.loaded_agent import (
    LoadedAgent,
    load_agent,
    load_shape_model,
    policy_settings,
    training_data,
)

__all__ = [
    "CELLS_DIR",
    "CODE_ROOT",
    "CORD_AGENTS",
    "CORD_ENVS",
    "DEFAULT_CORDS",
    "DEFAULT_DESIGNED",
    "DEFAULT_DIFFICULTIES",
    "DEFAULT_PEGS",
    "HEADLINE_THRESHOLD",
    "NEAR_REFERENCE",
    "PARTS_DIR",
    "PEG_AGENTS",
    "PEG_ENVS",
    "QUICK_DESIGNED_ENVS",
    "QUICK_DIFFICULTIES",
    "QUICK_EPISODES",
    "QUICK_SECTIONS",
    "RUN_FACTS",
    "SUITE_OF_DIFFICULTY",
    "THRESHOLDS",
    "BenchmarkConfig",
    "CodeState",
    "LoadedAgent",
    "absolute_paths",
    "agent_label",
    "cell_key",
    "cell_name",
    "code_state",
    "code_version",
    "cords_summary",
    "designed_summary",
    "designed_tasks",
    "env_label",
    "load_agent",
    "load_shape_model",
    "machine_label",
    "merge_parts",
    "new_run_id",
    "part_name",
    "peg_tasks",
    "policy_settings",
    "registered",
    "row_of",
    "run_benchmark",
    "run_cell",
    "split_episodes",
    "suite_label",
    "training_data",
]
