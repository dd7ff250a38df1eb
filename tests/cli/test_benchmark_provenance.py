"""What a benchmark records about how it was made: the commit of a committed tree, and the run
that timed each cell, so that planning times are compared only within one run."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

import dlo_bench.benchmark.provenance as provenance
from dlo_bench.benchmark import CodeState, code_state, new_run_id
from dlo_bench.benchmark_report import planning_time_ratios, ratio_lines
from dlo_cli.main import main

needs_git = pytest.mark.skipif(shutil.which("git") is None, reason="needs git")


def _git(*args: str, cwd: Path) -> None:
    subprocess.run(["git", "-c", "user.name=test", "-c", "user.email=test@example.org", *args],
                   cwd=cwd, check=True, capture_output=True, timeout=60)


@pytest.fixture
def clean_clone(tmp_path) -> Path:
    """A git checkout with one commit: a tracked file and an ignored runs/ folder."""
    root = tmp_path / "repo"
    root.mkdir()
    (root / "code.py").write_text("x = 1\n")
    (root / ".gitignore").write_text("/runs/\n")
    _git("init", "-q", cwd=root)
    _git("add", "code.py", ".gitignore", cwd=root)
    _git("commit", "-qm", "first", cwd=root)
    return root


@needs_git
def test_a_committed_checkout_is_clean_and_untracked_files_do_not_count(clean_clone):
    (clean_clone / "runs").mkdir()
    (clean_clone / "runs" / "results.json").write_text("{}")
    (clean_clone / "data.npz").write_text("untracked")
    state = code_state(clean_clone)
    assert state is not None and state.changed == () and state.version == state.commit
    assert len(state.commit) >= 7


@needs_git
def test_a_modified_or_staged_tracked_file_makes_the_checkout_dirty(clean_clone):
    (clean_clone / "code.py").write_text("x = 2\n")
    state = code_state(clean_clone)
    assert state.changed == ("code.py",) and state.version == f"{state.commit}+dirty"
    _git("add", "code.py", cwd=clean_clone)
    assert code_state(clean_clone).changed == ("code.py",)


@needs_git
def test_code_outside_a_checkout_of_its_own_has_no_state(clean_clone, tmp_path):
    assert code_state(tmp_path / "nowhere") is None
    assert code_state(tmp_path) is None  # not a checkout at all
    inner = clean_clone / "site-packages"  # an installed package inside another repository
    inner.mkdir()
    assert code_state(inner) is None


def _dirty(monkeypatch) -> None:
    state = CodeState(Path("/repo"), "abc1234", ("dlo_cli/flags.py", "README.md"))
    monkeypatch.setattr(provenance, "code_state", lambda root=None: state)


def test_benchmark_refuses_a_dirty_checkout_in_one_line_naming_allow_dirty(
        monkeypatch, tmp_path, capsys):
    _dirty(monkeypatch)
    out = tmp_path / "out"
    assert main(["benchmark", "--agent", "straight-line", "--out", str(out)]) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in captured.err and captured.out == ""
    assert lines[0].startswith("dlo benchmark: error: 2 tracked file(s)")
    assert "--allow-dirty" in lines[0] and "dlo_cli/flags.py" in lines[0]
    assert "abc1234" in lines[0]
    assert not out.exists()


def test_benchmark_outside_a_checkout_runs(monkeypatch, tmp_path):
    monkeypatch.setattr(provenance, "code_state", lambda root=None: None)
    out = tmp_path / "out"
    assert main(["benchmark", "--agent", "straight-line", "--env", "DLOEndpoint-v0",
                 "--difficulty", "1", "--episodes", "1", "--no-fidelity", "--out",
                 str(out)]) == 0
    assert json.loads((out / "results.json").read_text())[0]["commit"] == ""


def test_allow_dirty_runs_and_marks_every_cell_dirty_with_its_run(monkeypatch, tmp_path,
                                                                  capsys):
    _dirty(monkeypatch)
    out = tmp_path / "out"
    argv = ["benchmark", "--agent", "straight-line", "--env", "DLOEndpoint-v0",
            "--difficulty", "1", "2", "--episodes", "1", "--allow-dirty", "--out", str(out)]
    assert main(argv) == 0
    run = capsys.readouterr().out.splitlines()[0].split()[2].rstrip(":")
    rows = json.loads((out / "results.json").read_text())
    assert {(r["commit"], r["run"]) for r in rows} == {("abc1234+dirty", run)}
    assert main([*argv, "--resume"]) == 0  # reused cells keep the run that timed them
    assert {r["run"] for r in json.loads((out / "results.json").read_text())} == {run}
    table = (out / "results.md").read_text()
    assert "--allow-dirty" in table and f"{run} (6 cells)" in table


def _row(agent: str, difficulty: int, seconds: float, run: str) -> dict:
    return {"agent": agent, "env": "endpoint", "difficulty": difficulty, "status": "ok",
            "episodes": 50, "total_seconds": seconds, "run": run, "commit": "abc1234"}


def test_a_ratio_of_cells_timed_in_one_run_names_that_run():
    rows = [_row("physics-mpc", 1, 100.0, "R1"), _row("physics-mpc", 2, 300.0, "R1"),
            _row("latent-mpc", 1, 1.0, "R1"), _row("latent-mpc", 2, 3.0, "R1")]
    ratio = planning_time_ratios(rows, "physics-mpc", "latent-mpc")
    assert ratio.comparable and ratio.overall == pytest.approx(100.0)
    assert ratio.cells == {"endpoint d1": pytest.approx(100.0), "endpoint d2": pytest.approx(100.0)}
    assert ratio_lines(rows) == ["Planning time physics-mpc / latent-mpc on the same episodes, "
                                 "timed in one run (R1): 100x overall (endpoint d1 100x, "
                                 "endpoint d2 100x)."]


@pytest.mark.parametrize("runs", [("R1", "R2"), ("", "")])
def test_a_ratio_that_would_mix_runs_is_not_comparable_not_a_number(runs):
    rows = [_row("physics-mpc", 1, 100.0, runs[0]), _row("latent-mpc", 1, 1.0, runs[1])]
    assert not planning_time_ratios(rows, "physics-mpc", "latent-mpc").comparable
    (line,) = ratio_lines(rows)
    assert "not comparable" in line and "100x" not in line
    assert ("R1, R2" in line) if runs[0] else ("not recorded" in line)


def test_a_ratio_pairs_cells_run_by_run_and_names_the_mixed_ones():
    # An interrupted benchmark resumed later: each cell's two agents ran in one run.
    rows = [_row("physics-mpc", 1, 100.0, "R1"), _row("latent-mpc", 1, 1.0, "R1"),
            _row("physics-mpc", 2, 300.0, "R2"), _row("latent-mpc", 2, 6.0, "R2"),
            _row("physics-mpc", 3, 500.0, "R2"), _row("latent-mpc", 3, 1.0, "R3")]
    ratio = planning_time_ratios(rows, "physics-mpc", "latent-mpc")
    assert ratio.comparable and ratio.runs == ("R1", "R2") and ratio.mixed == ("endpoint d3",)
    assert ratio.overall == pytest.approx(400.0 / 7.0)
    (line,) = ratio_lines(rows)
    assert "each cell timed in one run (R1, R2): 57x overall" in line
    assert line.endswith("Not comparable, timed in different runs: endpoint d3.")


def test_run_ids_differ_and_sort_by_their_start():
    first, second = new_run_id(), new_run_id()
    assert first != second and first[:16] <= second[:16]


def test_every_cell_of_a_run_records_the_code_read_before_its_first_cell(tmp_path, monkeypatch):
    # A run writing into a tracked folder (--out benchmarks) dirties the tree as it goes: its
    # later cells must still record the commit that ran, not "+dirty" from its own output.
    import dlo_bench.benchmark.run as run
    from dlo_bench.benchmark import BenchmarkConfig, run_benchmark

    versions = iter(["abc1234", "abc1234+dirty", "abc1234+dirty"])
    monkeypatch.setattr(run, "code_version", lambda: next(versions))
    config = BenchmarkConfig(agents=("straight-line",), envs=("dlo_env/DLOEndpoint-v0",),
                             difficulties=(1, 2), thresholds=(0.02,), designed=(), episodes=1,
                             fidelity=False)
    rows = run_benchmark(config, tmp_path, progress=False)
    assert [row["commit"] for row in rows] == ["abc1234", "abc1234"]


def test_a_cell_records_a_shipped_model_relative_to_the_code_and_finds_it_again(tmp_path,
                                                                             monkeypatch):
    """results.json names shipped models relative to the code's root, so it reads the same on
    every machine and clone; a file outside the code stays as given."""
    shipped = provenance.CODE_ROOT / "latent_model" / "pretrained" / "transition.pt"
    assert provenance.code_path(shipped) == "latent_model/pretrained/transition.pt"
    assert provenance.code_file("latent_model/pretrained/transition.pt") == shipped
    outside = (tmp_path / "model.pt").resolve()
    assert provenance.code_path(outside) == str(outside)
    assert provenance.code_file(str(outside)) == outside
    # a relative path outside the code is recorded absolute, so it is found again from anywhere
    monkeypatch.chdir(tmp_path)
    assert provenance.code_path("model.pt") == str(outside)
    # Recorded paths are read against the code's root, not the current folder (a report
    # rewritten from elsewhere), an old absolute one below the root becomes relative, and a
    # label of a model passed in loaded stays.
    recorded = "latent_model/pretrained/transition.pt"
    assert provenance.recorded_path(recorded) == recorded
    assert provenance.recorded_path(str(shipped)) == recorded
    assert provenance.recorded_path("<TransitionModel passed in>") == \
        "<TransitionModel passed in>"
    assert provenance.model_label("<TransitionModel passed in>") == "<TransitionModel passed in>"
    assert provenance.model_label("model.pt") == str(outside)
