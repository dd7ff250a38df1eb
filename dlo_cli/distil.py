"""``dlo distil``: distil latent-mpc into a network by DAgger in the surrogate.

Writes ``<out>/latent-mpc-distilled[-dual-endpoint]/distilled.pt`` per environment, the
network the agent ``latent-mpc-distilled`` acts by, and resumes an interrupted run from the
``distil-state.pt`` beside it. The shipped networks are refreshed with
``--out dlo_bench/pretrained``.

Example:
    dlo distil --env DLOEndpoint-v0 DLODualEndpoint-v0
"""

from __future__ import annotations

import argparse

from dlo_cli.flags import (
    add_difficulty,
    add_env,
    add_out,
    add_seed,
    positive_int,
    writable_folder,
)

#: The agent the networks are for (its folder names in ``--out``).
AGENT = "latent-mpc-distilled"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Flags of ``dlo distil``."""
    from dlo_bench.distillation import DistillConfig
    from dlo_env.envs import ENVIRONMENTS

    d = DistillConfig()
    add_env(parser, [next(iter(ENVIRONMENTS))], "environments, one or several",
            accepted=tuple(ENVIRONMENTS), several=True)
    add_difficulty(parser, list(d.difficulties), "difficulties of the tasks drawn in the "
                                                 "surrogate")
    parser.add_argument("--rounds", type=positive_int, default=d.rounds,
                        help="DAgger rounds (the first rolls out latent-mpc's plans); more "
                             "rounds extend a finished run")
    parser.add_argument("--tasks", type=positive_int, default=d.tasks_per_round,
                        help="tasks rolled out per round")
    parser.add_argument("--horizon", type=positive_int, default=d.horizon,
                        help="most plans of a rollout")
    parser.add_argument("--epochs", type=positive_int, default=d.epochs,
                        help="passes over every label after each round")
    parser.add_argument("--width", type=positive_int, default=d.width,
                        help="hidden units of the network")
    add_seed(parser, "the tasks, latent-mpc and the network")
    add_out(parser, "distil", "the networks (<out>/latent-mpc-distilled[-dual-endpoint]/); "
                              "dlo_bench/pretrained holds the shipped ones")


def run(args: argparse.Namespace) -> int:
    """Distil for every environment (resuming), print where each network is."""
    from pathlib import Path

    from dlo_bench.distillation import DistillConfig, distil
    from dlo_bench.paths import baseline_folder_name
    from dlo_env.envs import ENVIRONMENTS

    writable_folder(args.out)
    for env_id in args.env:
        config = DistillConfig(grasp=ENVIRONMENTS[env_id][0],
                               difficulties=tuple(args.difficulty), rounds=args.rounds,
                               tasks_per_round=args.tasks,
                               horizon=args.horizon, epochs=args.epochs, width=args.width,
                               seed=args.seed)
        folder = Path(args.out) / baseline_folder_name(AGENT, env_id)
        print(f"{env_id}: distilling into {folder}", flush=True)
        path = distil(config, folder, log=lambda line: print(f"  {line}", flush=True))
        print(f"{env_id}: {path}")
    return 0
