"""Specification of the ``dlo collect`` command."""

from __future__ import annotations

import numpy as np
import pytest

import dlo_env.dataset.collect
from dlo_cli.main import main
from dlo_env.dataset.shape_file import load_shapes
from dlo_env.shapes import is_cord_like


def test_collect_writes_the_dataset_and_prints_a_summary_with_diversity(tmp_path, capsys):
    out = tmp_path / "d.npz"
    assert main(["collect", "shapes", "--num-shapes", "120", "--out", str(out), "--seed", "2"]) == 0
    data = load_shapes(out)
    assert data.shapes.shape == (120, 20, 2)
    assert data.metadata["seed"] == 2 and data.metadata["record_every"] == 10
    assert is_cord_like(data.shapes).all()
    text = capsys.readouterr().out
    assert f"wrote {out}" in text
    assert "120 accepted" in text and "rejected:" in text
    assert "grid coverage (10x10 over the table)" in text
    assert "distinct at 1 cm" in text and "turning angles" in text


def test_collect_flags_reach_the_configuration(tmp_path):
    out = tmp_path / "d.npz"
    args = ["collect", "shapes", "--num-shapes", "40", "--out", str(out), "--cosine-threshold",
            "0.9", "--record-every", "5"]
    assert main(args) == 0
    meta = load_shapes(out).metadata
    assert meta["cosine_threshold"] == 0.9 and meta["record_every"] == 5
    assert is_cord_like(load_shapes(out).shapes, 0.9).all()


def test_grasp_weights_and_push_fraction_choose_the_moves_of_a_shape_collection(tmp_path,
                                                                                capsys):
    out = tmp_path / "both.npz"
    assert main(["collect", "shapes", "--num-shapes", "300", "--out", str(out),
                 "--grasp-weights", "0.05", "0.05", "0.9", "--push-fraction", "0.7"]) == 0
    data = load_shapes(out)
    assert tuple(data.metadata["collect"]["grasp_weights"]) == (0.05, 0.05, 0.9)
    assert data.metadata["collect"]["push_fraction"] == 0.7
    both = data.transition_grasp[data.shape_transition] == 2
    assert both.mean() > 0.6  # both only while the ends are within the span limit
    assert main(["collect", "shapes", "--num-shapes", "5", "--grasp-weights", "0", "0", "1",
                 "--out", str(tmp_path / "z.npz")]) == 2
    assert "argument --grasp-weights: grasp_weights must be 3 non-negative weights (head, tail, " \
           "both) with head or tail > 0" in capsys.readouterr().err
    assert not (tmp_path / "z.npz").exists()


@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (["--num-shapes", "0"], "argument --num-shapes: expected a positive integer, got '0'"),
        (["--num-shapes", "ten"], "argument --num-shapes: expected a positive integer"),
        (["--workers", "0"], "argument --workers: expected a positive integer, got '0'"),
        (["--seed", "-3"], "argument --seed: expected an integer from 0 to 4294967295, got '-3'"),
        (["--cosine-threshold", "2"], "argument --cosine-threshold: expected a number in [-1, 1]"),
        (["--wide-fraction", "1.5"], "argument --wide-fraction: expected a number in [0, 1]"),
        (["--wide-fraction", "nan"], "argument --wide-fraction: expected a number in [0, 1]"),
        (["--wavy-fraction", "-1"], "argument --wavy-fraction: expected a number in [0, 1]"),
        (["--grasp-weights", "inf", "1", "1"], "argument --grasp-weights: expected a number >= 0"),
        (["--record-every", "0"], "argument --record-every: expected a positive integer"),
        (["--out", "d.csv"], "argument --out: expected a file name ending in .npz, got 'd.csv'"),
    ],
)
def test_bad_arguments_are_rejected_with_clear_messages(tmp_path, capsys, flags, message):
    kind = "transitions" if flags[0] in ("--wide-fraction", "--wavy-fraction") else "shapes"
    args = {f"--num-{kind}": "10", "--out": str(tmp_path / "d.npz")}
    args.update(dict(zip(flags[::2], flags[1::2])))
    assert main(["collect", kind, *[x for pair in args.items() for x in pair]]) == 2
    assert message in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


def test_missing_required_flags_are_named(capsys):
    assert main(["collect", "shapes", "--num-shapes", "10"]) == 2
    assert "--out" in capsys.readouterr().err


def test_an_existing_output_is_an_error_not_an_overwrite(tmp_path, capsys):
    out = tmp_path / "d.npz"
    out.write_bytes(b"keep me")
    assert main(["collect", "shapes", "--num-shapes", "10", "--out", str(out)]) == 2
    assert "already exists" in capsys.readouterr().err
    assert out.read_bytes() == b"keep me"


def test_interrupt_says_how_to_resume_and_resume_finishes(tmp_path, capsys, monkeypatch):
    out = tmp_path / "d.npz"
    real = dlo_env.dataset.collect.collect

    def interrupted(*args, **kwargs):
        def stop(accepted: int, rejected: int) -> None:
            raise KeyboardInterrupt

        return real(*args, **{**kwargs, "progress": stop})

    monkeypatch.setattr(dlo_env.dataset.collect, "collect", interrupted)
    assert main(["collect", "shapes", "--num-shapes", "30", "--out", str(out)]) == 130
    assert "--resume" in capsys.readouterr().err
    assert not out.exists()
    monkeypatch.setattr(dlo_env.dataset.collect, "collect", real)
    assert main(["collect", "shapes", "--num-shapes", "30", "--out", str(out), "--resume"]) == 0
    assert load_shapes(out).num_shapes == 30
    fresh = tmp_path / "fresh.npz"
    assert main(["collect", "shapes", "--num-shapes", "30", "--out", str(fresh)]) == 0
    np.testing.assert_array_equal(load_shapes(out).shapes, load_shapes(fresh).shapes)


def test_help_lists_every_flag(capsys):
    with pytest.raises(SystemExit):
        main(["collect", "shapes", "--help"])
    text = capsys.readouterr().out
    for flag in ("--num-shapes", "--out", "--seed", "--workers", "--cosine-threshold",
                 "--record-every", "--resume"):
        assert flag in text
