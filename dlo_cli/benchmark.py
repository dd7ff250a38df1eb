"""``dlo benchmark``: every agent on the test suites of both environments, one table."""

from __future__ import annotations

import argparse

from dlo_cli.flags import (
    add_agent,
    add_backend,
    add_difficulty,
    add_env,
    add_model,
    add_out,
    add_planner_flags,
    add_seed,
    add_transition_model,
    backend_of,
    existing_path,
    number_in,
    positive_int,
    writable_folder,
)
from dlo_env.errors import InputError


def field_flags() -> dict[str, str]:
    """``BenchmarkConfig`` field -> the flag that sets it, for the fields named otherwise."""
    return {"agents": "--agent", "cord_agents": "--agent", "peg_agents": "--agent",
            "envs": "--env", "difficulties": "--difficulty", "thresholds": "--threshold"}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Flags of ``dlo benchmark``; defaults are ``BenchmarkConfig``'s (the published table)."""
    from dlo_bench.benchmark import (
        DEFAULT_CORDS,
        DEFAULT_DIFFICULTIES,
        DEFAULT_PEGS,
        HEADLINE_THRESHOLD,
        QUICK_DESIGNED_ENVS,
        QUICK_DIFFICULTIES,
        QUICK_EPISODES,
        QUICK_SECTIONS,
        BenchmarkConfig,
    )
    from dlo_env.peg_suites import PEGGED_SUITES
    from dlo_env.tasks import SPLIT_SIZES

    size = SPLIT_SIZES["test"]
    parser.add_argument("--quick", action="store_true",
                        help=f"a smoke run of every agent and section: {QUICK_EPISODES} "
                             f"episode of each cell at {HEADLINE_THRESHOLD} m, of linear-"
                             f"{' linear-'.join(map(str, QUICK_DIFFICULTIES))} and "
                             + ", ".join(s for v in QUICK_SECTIONS.values() for s in v)
                             + " (the designed ones in " + " ".join(
                                 e.split("/")[-1] for e in QUICK_DESIGNED_ENVS) + "; flags "
                             "given say otherwise); with --jobs 2, about 3 minutes on 2 cores")
    parser.add_argument("--episodes", default=None, type=number_in(
                            int, 1, size, expected=f"an integer from 1 to {size} (the tasks of "
                                                   "a test split)"),
                        help="episodes per agent and difficulty, the first tasks of each test "
                             f"split (None: {BenchmarkConfig.episodes}, the whole split, so "
                             "every cell compares with the published table's 50 tasks per "
                             f"cell, unlike the quick looks of dlo evaluate; {QUICK_EPISODES} "
                             "with --quick)")
    add_agent(parser, default=list(BenchmarkConfig(cords=DEFAULT_CORDS).all_agents))
    add_env(parser, list(BenchmarkConfig.envs), "environments, one or several", several=True)
    defaults = "; ".join(f"{e.split('/')[-1]}: {' '.join(map(str, d))}"
                         for e, d in DEFAULT_DIFFICULTIES.items())
    add_difficulty(parser, None, "each runs the test split of suite linear-K in every "
                                 f"--env (None: {defaults}; `--difficulty` alone: none, to run "
                                 "the designed, cord or peg suites alone)", suites=True, nargs="*")
    parser.add_argument("--threshold", nargs="+", metavar="METRES", default=None,
                        type=number_in(float, 1e-4, 1.0, expected="a number of metres in "
                                                                  "[0.0001, 1]"),
                        help="success thresholds, metres: every cell runs once at each, judged "
                             "on the cord at rest (default: " + " ".join(
                                 map(str, BenchmarkConfig.thresholds)) + f"; {HEADLINE_THRESHOLD} "
                             "with --quick)")
    from dlo_env.designed_suites import DESIGNED_SUITES

    parser.add_argument("--designed", nargs="*", metavar="SUITE", default=None,
                        choices=tuple(DESIGNED_SUITES),
                        help="designed suites run in every --env at the headline threshold "
                             "(1 cm; the first --threshold without it), scored direction-free "
                             "(default: " + " ".join(
                                 BenchmarkConfig.designed) + "; " + " ".join(
                                 QUICK_SECTIONS["designed"]) + " with --quick; none with "
                             "--difficulty; `--designed` alone: none)")
    from dlo_env.cord_suites import CORD_SUITES

    parser.add_argument("--cords", nargs="*", metavar="SUITE", default=None,
                        choices=tuple(CORD_SUITES),
                        help="cord suites of the cords section (every task on its own held-out "
                             "cord, not told to the agents), run in " + " ".join(
                                 e.split("/")[-1] for e in BenchmarkConfig.cord_envs)
                             + " at the headline threshold by the agents of that section ("
                             + " ".join(BenchmarkConfig.cord_agents) + ") among --agent "
                             "(default: " + " ".join(DEFAULT_CORDS) + "; " + " ".join(
                                 QUICK_SECTIONS["cords"]) + " with --quick; none with "
                             "--difficulty; `--cords` alone: none)")
    parser.add_argument("--pegs", nargs="*", metavar="SUITE", default=None,
                        choices=tuple(PEGGED_SUITES),
                        help="suites with pegs of the pegs section (pegs-K: goals made among "
                             "pegs; route-K: goals that need the cord routed around a peg), run "
                             "in " + " ".join(e.split("/")[-1] for e in BenchmarkConfig.peg_envs)
                             + " observing the pegs, at the headline threshold (1 cm; the first "
                             "--threshold without it), by --agent "
                             "(RL agents: those trained with pegs, BASELINES/ALGO-pegs and "
                             "ALGO-pegs-dual-endpoint) "
                             "(default: " + " ".join(DEFAULT_PEGS) + "; " + " ".join(
                                 QUICK_SECTIONS["pegs"]) + " with --quick; none with "
                             "--difficulty; `--pegs` alone: none)")
    parser.add_argument("--baselines", default=BenchmarkConfig.baselines,
                        help="folder with one `dlo baseline` output folder per RL agent and "
                             "environment (BASELINES/ppo, BASELINES/sac-her, BASELINES/bc; "
                             "BASELINES/ppo-dual-endpoint... for DLODualEndpoint-v0; None: the "
                             "shipped ones)")
    add_model(parser)
    add_transition_model(parser)
    parser.add_argument("--cords-transition-model", default=None, metavar="FILE",
                        type=existing_path("transition model"),
                        help="transition model of several cords (dlo train transition "
                             "--cord-inputs), file or folder, for latent-mpc-adaptive (None: "
                             "the shipped latent_model/pretrained/transition-cords.pt)")
    parser.add_argument("--pegs-transition-model", default=None, metavar="FILE",
                        type=existing_path("transition model"),
                        help="transition model of the pegs section's agents, file or folder (a "
                             "model that sees pegs: dlo train transition --peg-reach; "
                             "None: the shipped latent_model/pretrained/transition-pegs.pt)")
    add_planner_flags(parser)
    add_seed(parser, "the planners' sampling (the tasks are the suites')",
             default=BenchmarkConfig.seed)
    add_backend(parser, "this process, one cell after the other")
    parser.add_argument("--jobs", type=positive_int, default=1,
                        help="cells run at once, each in its own local process (every cell "
                             "the same as when run alone; with more jobs than idle cores the "
                             "timings include the contention)")
    parser.add_argument("--part-episodes", type=positive_int, default=None, metavar="N",
                        help="run each cell in parts of N episodes, each written to "
                             "results_episodes/parts/ as it finishes (--resume loses no "
                             "finished part; with --jobs the parts of one slow cell run at "
                             "once); the cell is the same as when run whole (default: whole "
                             "cells)")
    parser.add_argument("--resume", action="store_true",
                        help="reuse the cells (and parts) an interrupted run with the same "
                             "settings wrote")
    parser.add_argument("--allow-dirty", action="store_true",
                        help="run even though tracked files of the code's git checkout have "
                             "uncommitted changes (its cells are then marked COMMIT+dirty); "
                             "without it the benchmark refuses, so that committed results come "
                             "from a commit")
    add_out(parser, "benchmark", "results.md/.json/.png and results_episodes/; "
                                 "`--out benchmarks` refreshes the committed results")


def check_committed(allow_dirty: bool) -> None:
    """Refuse (``ValueError``, one line naming ``--allow-dirty``) to run code with uncommitted
    changes to tracked files, unless ``allow_dirty``; code outside a git checkout of its own
    (an installed package) runs."""
    from dlo_bench.benchmark.provenance import code_state

    state = code_state()
    if allow_dirty or state is None or not state.changed:
        return
    shown = ", ".join(state.changed[:3]) + (", ..." if len(state.changed) > 3 else "")
    raise InputError(f"{len(state.changed)} tracked file(s) of {state.root} have uncommitted "
                     f"changes ({shown}): results record the commit they ran ({state.commit}), "
                     "so commit first, or pass --allow-dirty to run anyway (marked "
                     f"{state.commit}+dirty)")


def _command(args: argparse.Namespace, parser_defaults: dict) -> str:
    """The command line that reproduces this run (flags that differ from the defaults)."""
    parts = ["dlo benchmark"]
    for key, value in vars(args).items():
        if key.startswith("_") or key in ("command", "debug") or value == parser_defaults.get(key):
            continue
        flag = "--" + key.replace("_", "-")
        if value is True:
            parts.append(flag)
        elif isinstance(value, list):
            parts.append(f"{flag} {' '.join(map(str, value))}")
        else:
            parts.append(f"{flag} {value}")
    return " ".join(parts)


def section_suites(args: argparse.Namespace, flag: str = "designed") -> list[str]:
    """The designed (or with ``flag="cords"``, cord; ``"pegs"``, peg) suites to run:
    ``--designed`` as given (alone: none); none with ``--difficulty`` (a subset of cells);
    ``QUICK_SECTIONS``' with ``--quick``; by default the config's."""
    from dlo_bench.benchmark import DEFAULT_CORDS, DEFAULT_PEGS, QUICK_SECTIONS, BenchmarkConfig

    given = getattr(args, flag)
    if given is not None:
        return list(dict.fromkeys(given))
    if args.difficulty is not None:
        return []
    if args.quick:
        return list(QUICK_SECTIONS[flag])
    return list({"designed": BenchmarkConfig.designed, "cords": DEFAULT_CORDS,
                 "pegs": DEFAULT_PEGS}[flag])


def split_agents(names: list[str], cords: bool) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """``--agent`` as the config's ``agents`` (every name but the agents of the cords section
    only) and ``cord_agents`` (the names of ``CORD_AGENTS`` and of those, when cord suites
    run)."""
    from dlo_bench.agents import agent_spec
    from dlo_bench.benchmark import CORD_AGENTS

    names = list(dict.fromkeys(names))
    agents = tuple(a for a in names if not agent_spec(a).cords)
    cord_agents = tuple(a for a in names if agent_spec(a).cords or a in CORD_AGENTS) if cords \
        else ()
    if not agents and not cord_agents:
        raise InputError(f"--agent names only agents of the cords section ({' '.join(names)}), "
                         "but no cord suite runs: add --cords SUITE")
    return agents, cord_agents


def run(args: argparse.Namespace) -> int:
    """Run the benchmark, print the table and the speed ratio, write the results."""
    import time

    from dlo_bench.benchmark import (
        HEADLINE_THRESHOLD,
        PEG_AGENTS,
        QUICK_DESIGNED_ENVS,
        QUICK_DIFFICULTIES,
        QUICK_EPISODES,
        BenchmarkConfig,
    )

    thresholds = args.threshold
    if thresholds is None:
        thresholds = [HEADLINE_THRESHOLD] if args.quick else list(BenchmarkConfig.thresholds)
    designed = section_suites(args)
    cords = section_suites(args, "cords")
    pegs = section_suites(args, "pegs")
    agents, cord_agents = split_agents(args.agent, bool(cords))
    peg_agents = tuple(a for a in agents if a in PEG_AGENTS)
    episodes = args.episodes if args.episodes is not None else (
        QUICK_EPISODES if args.quick else BenchmarkConfig.episodes)
    config = BenchmarkConfig(
        agents=agents, cord_agents=cord_agents, envs=tuple(args.env),
        difficulties=(tuple(args.difficulty) if args.difficulty is not None
                      else QUICK_DIFFICULTIES if args.quick else None),
        thresholds=tuple(thresholds), designed=tuple(dict.fromkeys(designed)),
        designed_envs=(tuple(e for e in QUICK_DESIGNED_ENVS if e in args.env) or None
                       if args.quick and args.designed is None else None),
        cords=tuple(cords), pegs=tuple(pegs), peg_agents=peg_agents,
        episodes=episodes,
        seed=args.seed, baselines=args.baselines, model=args.model,
        transition_model=args.transition_model,
        cords_transition_model=args.cords_transition_model,
        pegs_transition_model=args.pegs_transition_model,
        replan_every=args.replan_every, max_seconds=args.max_seconds,
        fidelity=not args.no_fidelity,
    )
    check_committed(args.allow_dirty)  # before anything is built or written

    import torch

    from dlo_bench.benchmark import new_run_id, run_benchmark, suite_label
    from dlo_bench.benchmark_report import ratio_lines, write_results
    from dlo_bench.report import threshold_label

    torch.set_num_threads(args.threads)
    backend = backend_of(args)
    if args.jobs > 1:
        if backend is not None:
            raise InputError("--jobs runs the cells in local processes; with --backend ray the "
                             "cluster's CPUs set how many run at once")
        from dlo_env.core.process_backend import ProcessBackend

        backend = ProcessBackend(args.jobs)
    writable_folder(args.out)  # the last check: a bad command line leaves no folder
    run_id = new_run_id()
    groups: dict[float, list[str]] = {}
    for env, suite, t in config.cells():
        groups.setdefault(t, []).append(f"{env.split('/')[-1]} {suite_label(suite)}")
    cells = "; ".join(f"{threshold_label(t)}: {', '.join(names)}" for t, names in groups.items())
    print(f"benchmark run {run_id}: {len(config.all_agents)} agents x {config.episodes} episodes "
          f"x {len(config.cells())} cells ({cells}) -> {args.out}", flush=True)
    t0 = time.perf_counter()
    rows = run_benchmark(config, args.out, resume=args.resume, progress=True,
                         backend=backend, run_id=run_id, part=args.part_episodes)
    seconds = time.perf_counter() - t0
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    paths = write_results(rows, args.out, _command(args, vars(parser.parse_args([]))), seconds)
    from dlo_bench.benchmark_report import (
        cords_section,
        headline_first,
        is_main_row,
        pegs_section,
        success_table,
        thresholds_of,
    )

    for t in headline_first(thresholds_of([r for r in rows if is_main_row(r)])):
        print(f"success at {threshold_label(t)}, judged at rest:")
        print("\n".join(success_table(rows, t)))
    for section in (cords_section(rows), pegs_section(rows)):
        tables = [line for line in section if line.startswith(("|", "**"))]  # not the prose
        if tables:
            print("\n".join(tables))
    print("\n".join(ratio_lines(rows)) or "planning time ratios not measured: physics-mpc did "
                                          "not run with a cheaper planner")
    missing = sorted({r["agent"] for r in rows if r["status"] == "missing"})
    if missing:
        print("agents with missing cells (reported in the table): " + ", ".join(missing))
    print(f"wrote {', '.join(str(p) for p in paths.values())} in {seconds:.0f} s")
    return 0
