"""``dlo export-minari``: the suites' oracle demonstrations and transition data as Minari
datasets.

Examples:
    dlo export-minari                                   # demonstrations: every suite, both envs
    dlo export-minari --transitions runs/transitions.npz --no-demonstrations
    dlo export-minari --root runs/minari --suite linear-1 --limit 20
"""

from __future__ import annotations

import argparse

from dlo_cli.flags import add_env, existing_path, positive_int, writable_folder
from dlo_env.errors import InputError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``dlo export-minari``."""
    from dlo_env.dataset.minari_export import ENVIRONMENTS
    from dlo_env.tasks import SUITES

    parser.add_argument("--root", default=None,
                        help="Minari dataset root to write into (None: Minari's own, "
                             "$MINARI_DATASETS_PATH or ~/.minari/datasets, where "
                             "minari.load_dataset finds them)")
    parser.add_argument("--suite", nargs="+", default=list(SUITES), choices=list(SUITES),
                        help="suites whose train-split demonstrations are exported")
    add_env(parser, list(ENVIRONMENTS), "environments of the demonstrations",
            accepted=ENVIRONMENTS, several=True)
    parser.add_argument("--limit", type=positive_int, default=None,
                        help="only the first LIMIT train tasks of each suite (None: all 200)")
    parser.add_argument("--no-demonstrations", action="store_true",
                        help="skip the demonstrations (export only --transitions)")
    parser.add_argument("--transitions", default=None, metavar="FILE",
                        type=existing_path("transitions"),
                        help="also export this `dlo collect transitions` file")
    parser.add_argument("--name", default="transitions",
                        help="dataset name of the transition data: dlo/endpoint/NAME-v0")


def run(args: argparse.Namespace) -> int:
    """Write the datasets, printing one line per dataset."""
    from dlo_env.core.progress import progress_bar
    from dlo_env.dataset.minari_export import (
        check_absent,
        check_name,
        demonstrations_id,
        export_demonstrations,
        export_transitions,
        transitions_ids,
    )

    if args.no_demonstrations and args.transitions is None:
        raise InputError("--no-demonstrations leaves nothing to export; give --transitions FILE")
    # Everything that can be refused is, before the first episode is recorded.
    args.env, args.suite = list(dict.fromkeys(args.env)), list(dict.fromkeys(args.suite))
    planned = [] if args.no_demonstrations else [
        demonstrations_id(env_id, suite) for env_id in args.env for suite in args.suite]
    if args.transitions is not None:
        try:
            check_name(args.name)
        except InputError as exc:
            raise InputError(f"--name: {exc}") from None
        try:
            planned += transitions_ids(args.transitions, args.name)
        except InputError as exc:
            raise InputError(f"--transitions: {exc}") from None
    if args.root is not None:
        writable_folder(args.root, "--root")
    check_absent(planned, args.root)
    written = []
    if args.transitions is not None:  # first: its replay check is the one step that can fail
        written.extend(export_transitions(args.transitions, name=args.name, root=args.root))
    if not args.no_demonstrations:
        for env_id in args.env:
            for suite in args.suite:
                bar = progress_bar(args.limit or 200, desc=f"{env_id} {suite}", unit="episode")
                try:
                    written.append(export_demonstrations(
                        env_id, suite, root=args.root, limit=args.limit,
                        progress=lambda done, _, bar=bar: bar.update(done)))
                finally:
                    bar.close()
    for d in written:
        replay = f", replayed within {d.replay_error:.1e} m" if d.replay_error else ""
        print(f"{d.dataset_id}: {d.episodes} episodes, {d.steps} steps, {d.solved} end "
              f"solved{replay}")
    where = args.root if args.root is not None else "Minari's dataset root"
    print(f"wrote {len(written)} datasets into {where}; load one with "
          f"minari.load_dataset({written[0].dataset_id!r})" if written else "nothing written")
    return 0

