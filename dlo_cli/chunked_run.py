"""A chunked collection run with a progress bar, shared by ``dlo collect shapes`` and
``dlo collect transitions``."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any


def run_chunked(args: argparse.Namespace, job: Callable[[Callable[[int, int], None]], Any],
                total: int, unit: str,
                postfix: Callable[[int, int], str] | None = None) -> tuple[Any, float] | None:
    """Run a chunked collection ``job(progress)`` with a progress bar; print what was written.

    Returns:
        ``(dataset, seconds)``, or None after Ctrl-C (the kept chunks and ``--resume`` are
        named on stderr).
    """
    import os
    import sys
    import time

    from dlo_cli.flags import writable_file
    from dlo_env.core.progress import progress_bar
    from dlo_env.dataset.chunks import parts_dir

    writable_file(args.out)

    bars: list = []  # opened on the first report, so argument errors print no bar

    def progress(done: int, rejected: int) -> None:
        if not bars:
            bars.append(progress_bar(total, desc="collect", unit=unit))
        if postfix is not None:
            bars[0].set_postfix_str(postfix(done, rejected), refresh=False)
        bars[0].update(done)

    started = time.perf_counter()
    try:
        data = job(progress)
    except KeyboardInterrupt:
        print(f"\ninterrupted: finished chunks are kept in {parts_dir(args.out)}; run the same "
              "command with --resume to continue", file=sys.stderr)
        return None
    finally:
        for bar in bars:
            bar.close()
    elapsed = time.perf_counter() - started
    meta = data.metadata
    print(f"wrote {args.out} ({os.path.getsize(args.out) / 1e6:.1f} MB) in {elapsed:.1f} s")
    if meta["chunks_resumed"]:
        print(f"  resumed {meta['chunks_resumed']} of {meta['chunks']} chunks")
    return data, elapsed
