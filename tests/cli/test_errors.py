"""Errors a user can act on: one line on stderr naming what to fix, exit status 2, no traceback.

``--debug`` shows the traceback instead.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from dlo_cli.errors import EXTRAS
from dlo_cli.main import main


def _one_line_error(capsys, code: int) -> str:
    assert code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


def test_a_missing_data_file_is_one_line(tmp_path, capsys):
    line = _one_line_error(capsys, main(["train", "--data", str(tmp_path / "nope.npz"),
                                         "--out", str(tmp_path / "run")]))
    assert line.startswith("dlo train: error:") and "nope.npz" in line


def test_a_corrupt_data_file_is_one_line_that_says_so(tmp_path, capsys):
    bad = tmp_path / "corrupt.npz"
    bad.write_bytes(b"this is not an npz archive")
    line = _one_line_error(capsys, main(["train", "--data", str(bad), "--out",
                                         str(tmp_path / "run")]))
    assert "not a readable .npz file" in line and "pickled" not in line


def test_an_unknown_suite_is_one_line_naming_the_suites(tmp_path, capsys):
    line = _one_line_error(capsys, main(["evaluate", "--agent", "straight-line", "--suite",
                                         "linear-9", "--out", str(tmp_path)]))
    assert "linear-9" in line and "linear-1" in line


def test_an_unknown_agent_is_one_line_naming_the_agents(tmp_path, capsys):
    line = _one_line_error(capsys, main(["evaluate", "--agent", "teleport", "--out",
                                         str(tmp_path)]))
    assert "teleport" in line and "straight-line" in line


def test_an_agent_in_an_environment_it_does_not_act_in_is_one_line(tmp_path, capsys,
                                                                   monkeypatch):
    # Every registered agent acts in both environments; one that does not is refused.
    from dataclasses import replace

    from dlo_bench import agents

    spec = replace(agents.AGENTS["straight-line"], environments=("dlo_env/DLOEndpoint-v0",))
    monkeypatch.setitem(agents.AGENTS, "straight-line", spec)
    line = _one_line_error(capsys, main(["evaluate", "--agent", "straight-line", "--env",
                                         "dlo_env/DLODualEndpoint-v0", "--out", str(tmp_path)]))
    assert "--agent straight-line acts in dlo_env/DLOEndpoint-v0" in line and "--env" in line


def test_a_shape_model_for_another_cord_is_one_line(tmp_path, capsys):
    from latent_model import ShapeModel
    from latent_model.config import ModelConfig
    from latent_model.normalisation import Normalisation

    ShapeModel(ModelConfig(n_points=12), Normalisation(), device="cpu").save(tmp_path / "m.pt")
    line = _one_line_error(capsys, main(["evaluate", "--agent", "latent-tree", "--model",
                                         str(tmp_path / "m.pt"), "--out", str(tmp_path)]))
    assert "n_points=12" in line and "n_points=20" in line


def test_a_missing_optional_dependency_names_the_extra_that_installs_it(monkeypatch, capsys):
    def run(args):
        raise ModuleNotFoundError("No module named 'stable_baselines3'", name="stable_baselines3")

    monkeypatch.setattr("dlo_cli.baseline.run", run)
    line = _one_line_error(capsys, main(["baseline", "--algo", "ppo"]))
    assert 'pip install "dlo[rl]"' in line and 'pip install -e ".[rl]"' in line


def test_every_optional_dependency_maps_to_an_extra_of_the_package():
    from pathlib import Path

    tomllib = pytest.importorskip("tomllib")  # Python 3.11+

    pyproject = tomllib.loads((Path(__file__).parents[2] / "pyproject.toml").read_text())
    assert set(EXTRAS.values()) <= set(pyproject["project"]["optional-dependencies"])


def test_debug_shows_the_traceback_instead(tmp_path):
    with pytest.raises(FileNotFoundError):
        main(["--debug", "train", "--data", str(tmp_path / "nope.npz"), "--out", str(tmp_path)])
    with pytest.raises(FileNotFoundError):
        main(["train", "--debug", "--data", str(tmp_path / "nope.npz"), "--out", str(tmp_path)])


def test_version_prints_the_package_version(capsys):
    from importlib import metadata

    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    assert capsys.readouterr().out.strip() == f"dlo {metadata.version('dlo')}"


def test_every_flag_of_every_command_has_help(capsys):
    from dlo_cli.main import build_parser

    parser = build_parser()
    commands = parser._subparsers._group_actions[0].choices  # noqa: SLF001 (argparse has no API)
    for name, sub in commands.items():
        for action in sub._actions:
            assert action.help, f"dlo {name} {action.option_strings} has no help"


def test_collect_runs_on_the_core_install_without_tqdm_torch_or_matplotlib(tmp_path):
    out = tmp_path / "d.npz"
    blocked = "; ".join(f"sys.modules[{m!r}] = None" for m in ("tqdm", "torch", "matplotlib"))
    code = (f"import sys; {blocked}; from dlo_cli.main import main; "
            f"sys.exit(main(['collect', '--num-shapes', '30', '--out', {str(out)!r}]))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    with np.load(out, allow_pickle=False) as data:
        assert data["shapes"].shape == (30, 20, 2)


@pytest.mark.parametrize("stage, flags, named", [
    ("gan", ["--teacher", "model.pt"], "--teacher applies to --stage transition only"),
    ("all", ["--lr", "1e-3"], "--lr applies to --stage transition only"),
    ("encoder", ["--peg-reach", "0.1"], "--peg-reach applies to --stage transition only"),
    ("transition", ["--gan-steps", "5"], "--gan-steps applies to --stage gan, encoder or all"),
    ("transition", ["--minutes", "3"], "--minutes applies to --stage gan, encoder or all"),
    ("transition", ["--report-size", "9"], "--report-size applies to --stage gan, encoder"),
    ("all", ["--miss-weight", "0"], "--miss-weight applies to --stage transition only"),
    ("transition", ["--minutes", "0"], "--minutes applies to --stage gan, encoder or all"),
    ("gan", ["--contact-reach", "0.03"], "--contact-reach applies to --stage transition only"),
    ("all", ["--mean-by-grasp"], "--mean-by-grasp applies to --stage transition only"),
])
def test_a_flag_the_stage_would_ignore_is_one_line_naming_it(stage, flags, named, tmp_path,
                                                             capsys):
    line = _one_line_error(capsys, main(["train", "--stage", stage, "--data",
                                         str(tmp_path / "x.npz"), "--out", str(tmp_path / "r"),
                                         *flags]))
    assert named in line and f"not to --stage {stage}" in line
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize("flag", ["--miss-weight", "--miss-margin", "--teacher-weight",
                                  "--contact-reach"])
@pytest.mark.parametrize("value", ["-1", "inf", "nan"])
def test_a_loss_weight_that_is_negative_or_not_finite_is_refused_before_any_data_loads(
        flag, value, tmp_path, capsys):
    line = _one_line_error(capsys, main(["train", "--stage", "transition", "--data",
                                         str(tmp_path / "x.npz"), "--out", str(tmp_path / "r"),
                                         flag, value]))
    assert line == f"dlo train: error: argument {flag}: expected a number >= 0, got '{value}'"
    assert not (tmp_path / "r").exists()
