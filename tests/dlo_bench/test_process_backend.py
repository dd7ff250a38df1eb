"""Benchmark cells in local worker processes (dlo_env.core.process_backend, --jobs)."""

from __future__ import annotations

import operator
import sys

import pytest

from dlo_bench.cell_store import read_cell
from dlo_cli.main import main
from dlo_env.core.process_backend import ProcessBackend


def test_map_yields_every_result_with_its_index_and_raises_a_calls_error():
    calls = [(2, 3), (4, 5), (6, 7)]
    assert sorted(ProcessBackend(2).map(operator.mul, calls)) == [(0, 6), (1, 20), (2, 42)]
    with pytest.raises(ZeroDivisionError):
        list(ProcessBackend(2).map(operator.truediv, [(1, 1), (1, 0)]))
    with pytest.raises(ValueError, match="workers must be an int >= 1"):
        ProcessBackend(0)


def test_benchmark_cells_in_two_processes_equal_the_local_ones(tmp_path, capsys):
    args = ["benchmark", "--agent", "straight-line", "--env", "DLOEndpoint-v0", "--difficulty",
            "1", "2", "--episodes", "2", "--threshold", "0.02", "--allow-dirty"]
    assert main([*args, "--out", str(tmp_path / "one")]) == 0
    assert main([*args, "--out", str(tmp_path / "two"), "--jobs", "2"]) == 0
    for cell in ("straight-line-endpoint-d1-2cm", "straight-line-endpoint-d2-2cm"):
        one, two = (read_cell(tmp_path / run / "results_episodes" / f"{cell}.npz")
                    for run in ("one", "two"))
        assert one["summary"]["success_rate"] == two["summary"]["success_rate"]
        assert [r["final_error"] for r in one["records"]] == \
            [r["final_error"] for r in two["records"]]
    capsys.readouterr()
    assert main([*args, "--out", str(tmp_path / "x"), "--jobs", "2", "--backend", "ray"]) == 2
    assert "--jobs runs the cells in local processes" in capsys.readouterr().err


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_workers_exit_when_their_parent_is_killed(tmp_path):
    """SIGTERM on a run with --jobs runs no clean-up: its workers must not go on as orphans."""
    import os
    import signal
    import subprocess
    import time
    from pathlib import Path

    import dlo_env

    pids = tmp_path / "worker.pid"
    script = (
        "import os, sys, time\n"
        "from dlo_env.core.process_backend import ProcessBackend\n"
        "def work(path):\n"
        "    open(path, 'w').write(str(os.getpid()))\n"
        "    time.sleep(120)\n"
        "if __name__ == '__main__':\n"
        f"    list(ProcessBackend(1).map(work, [({str(pids)!r},)]))\n"
    )
    (tmp_path / "parent.py").write_text(script)  # a file: spawned workers import its `work`
    code = str(Path(dlo_env.__file__).resolve().parents[1])  # this checkout's code
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        p for p in (code, os.environ.get("PYTHONPATH")) if p)}
    parent = subprocess.Popen([sys.executable, str(tmp_path / "parent.py")], env=env)

    def running(pid: int) -> bool:
        """Alive and not a zombie (an exited child its new parent has not reaped yet)."""
        try:
            stat = Path(f"/proc/{pid}/stat").read_text()
        except (FileNotFoundError, ProcessLookupError):
            return False
        return stat.rsplit(")", 1)[1].split()[0] != "Z"

    worker = None
    try:
        deadline = time.monotonic() + 60
        while not (pids.is_file() and pids.read_text()) and time.monotonic() < deadline:
            time.sleep(0.1)
        worker = int(pids.read_text())
        parent.send_signal(signal.SIGTERM)
        parent.wait(timeout=30)
        deadline = time.monotonic() + 15
        while running(worker) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert not running(worker)
    finally:
        parent.kill()
        if worker is not None and running(worker):
            os.kill(worker, signal.SIGKILL)
