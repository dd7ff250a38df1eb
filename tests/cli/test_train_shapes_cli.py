"""``dlo train`` of the shape model on several shape files, with the report by the ends driven."""

from __future__ import annotations

import json

from dlo_cli.main import main


def test_train_joins_shape_files_and_reports_each_group_of_held_out_shapes(tmp_path, capsys):
    files = {}
    for name, seed, weights in (("a", 0, "0.5 0.5 0"), ("b", 1, "0.05 0.05 0.9"),
                                ("c", 2, "0.3 0.3 0.4"), ("d", 3, "0.05 0.05 0.9")):
        files[name] = str(tmp_path / f"{name}.npz")
        assert main(["collect", "shapes", "--num-shapes", "400", "--seed", str(seed),
                     "--grasp-weights", *weights.split(), "--out", files[name]]) == 0
    out = tmp_path / "run"
    assert main(["train", "shape", "--data", files["a"], files["b"], "--heldout", files["c"],
                 files["d"], "--out", str(out), "--gan-steps", "4", "--encoder-steps", "2",
                 "--width", "16", "--eval-every", "4", "--report-size", "120",
                 "--no-progress"]) == 0
    text = capsys.readouterr().out
    assert "800 training shapes, 800 held-out shapes" in text
    assert "by the ends driven" in text
    report = json.loads((out / "report.json").read_text())
    groups = report["groups"]
    assert set(groups) == {"one end", "both ends"}
    assert sum(g["n_reference"] for g in groups.values()) == report["n_reference"] == 120
    assert sum(g["n_inversion"] for g in groups.values()) == report["n_inversion"]
    # The whole-set coverage is the reference-weighted mean of the groups'.
    weighted = sum(g["cov"] * g["n_reference"] for g in groups.values()) / 120
    assert abs(weighted - report["cov"]) < 1e-6
    assert main(["train", "shape", "--data", files["a"], "--heldout", str(tmp_path / "nope.npz"),
                 "--out", str(tmp_path / "other")]) == 2
    assert "--heldout: no dataset file at" in capsys.readouterr().err
