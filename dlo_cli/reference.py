"""``dlo reference``: the reference errors of a designed suite's test tasks.

For every task, the best direction-free error at rest that a long-budget physics search reached
(``dlo_bench.reference``). Resumes from the file in ``--out``; the shipped files are refreshed
with ``--out dlo_bench/references``.

Example:
    dlo reference --suite shapes-curves --env DLOEndpoint-v0 DLODualEndpoint-v0 --jobs 2
"""

from __future__ import annotations

import argparse

from dlo_cli.flags import add_env, add_out, positive_int, writable_folder


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Flags of ``dlo reference``."""
    from dlo_env.designed_suites import DESIGNED_SUITES
    from dlo_env.envs import ENVIRONMENTS

    parser.add_argument("--suite", choices=tuple(DESIGNED_SUITES),
                        default=next(iter(DESIGNED_SUITES)), help="the designed suite")
    add_env(parser, list(ENVIRONMENTS), "environments, one or several", several=True)
    parser.add_argument("--limit", type=positive_int, default=None,
                        help="only the first LIMIT test tasks (None: all)")
    parser.add_argument("--jobs", type=positive_int, default=1, help="worker processes")
    add_out(parser, "reference", "the reference files (<suite>-<env>.json); "
                                 "dlo_bench/references holds the shipped ones")


def run(args: argparse.Namespace) -> int:
    """Search every task (resuming), print where the files are and their summary."""
    import json

    import numpy as np

    from dlo_bench.reference import make_references

    writable_folder(args.out)
    for env_id in args.env:
        path = make_references(args.suite, env_id, args.out, limit=args.limit, jobs=args.jobs,
                               progress=True)

        rows = json.loads(path.read_text())["tasks"]
        errors = np.array([r["error"] for r in rows])
        print(f"{env_id}: {len(rows)} tasks, median {100 * np.median(errors):.2f} cm, within "
              f"1 cm {np.mean(errors <= 0.01):.0%}, within 2 cm {np.mean(errors <= 0.02):.0%} "
              f"-> {path}")
    return 0
