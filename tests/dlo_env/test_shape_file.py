"""Specification of the shape dataset file format (dlo_env.dataset.shape_file)."""

from __future__ import annotations

import json
import zipfile

import numpy as np
import pytest

from dlo_env.dataset.shape_file import (
    ARRAY_NAMES,
    FORMAT_VERSION,
    ShapeDataset,
    load_shapes,
    save_shapes,
    split,
)
from dlo_env.shapes import random_cord_shape


def make_dataset(episodes: int = 6, moves: int = 3, per_move: int = 4, seed: int = 0):
    """A small consistent dataset without simulation: every move records ``per_move`` shapes."""
    rng = np.random.default_rng(seed)
    t = episodes * moves
    shapes = np.array([random_cord_shape(rng) for _ in range(t * per_move)], dtype=np.float32)
    return ShapeDataset(
        shapes=shapes,
        shape_transition=np.repeat(np.arange(t, dtype=np.int64), per_move),
        transition_before=shapes[::per_move].copy(),
        transition_after=shapes[per_move - 1 :: per_move].copy(),
        transition_grasp=(np.arange(t) % 3).astype(np.int8),
        transition_displacement=rng.normal(0, 0.1, (t, 2, 2)).astype(np.float32),
        transition_episode=np.repeat(np.arange(episodes, dtype=np.int64), moves),
        transition_cord_like=np.ones(t, dtype=bool),
        metadata={"seed": seed, "note": "synthetic"},
    )


def rewrite(path, **changes):
    """Copy of the file at ``path`` with some members replaced (None removes one)."""
    with np.load(path, allow_pickle=False) as npz:
        members = {name: npz[name] for name in npz.files}
    for name, value in changes.items():
        if value is None:
            members.pop(name)
        else:
            members[name] = value
    np.savez(path, **members)


def test_save_then_load_returns_the_same_arrays_and_metadata(tmp_path):
    data = make_dataset()
    save_shapes(tmp_path / "d.npz", data)
    loaded = load_shapes(tmp_path / "d.npz")
    for name in ARRAY_NAMES:
        np.testing.assert_array_equal(getattr(loaded, name), getattr(data, name))
        assert getattr(loaded, name).dtype == getattr(data, name).dtype
    assert loaded.metadata["note"] == "synthetic"
    assert loaded.metadata["format_version"] == FORMAT_VERSION
    assert loaded.num_shapes == 72 and loaded.num_transitions == 18


def test_file_is_plain_npz_with_json_metadata_and_no_pickles(tmp_path):
    save_shapes(tmp_path / "d.npz", make_dataset())
    with np.load(tmp_path / "d.npz", allow_pickle=False) as npz:
        assert set(npz.files) == set(ARRAY_NAMES) | {"metadata"}
        meta = json.loads(str(npz["metadata"]))
        assert npz["shapes"].shape == (72, 20, 2) and npz["shapes"].dtype == np.float32
    assert meta["format"] == "dlo-shapes"


def test_equal_datasets_give_byte_identical_files(tmp_path):
    save_shapes(tmp_path / "a.npz", make_dataset())
    save_shapes(tmp_path / "b.npz", make_dataset())
    assert (tmp_path / "a.npz").read_bytes() == (tmp_path / "b.npz").read_bytes()


def test_save_leaves_no_temporary_file(tmp_path):
    save_shapes(tmp_path / "d.npz", make_dataset())
    assert [p.name for p in tmp_path.iterdir()] == ["d.npz"]


def test_missing_file_is_reported_with_how_to_make_one(tmp_path):
    with pytest.raises(FileNotFoundError, match="dlo collect"):
        load_shapes(tmp_path / "nothing.npz")


def test_wrong_format_version_is_rejected(tmp_path):
    path = tmp_path / "d.npz"
    save_shapes(path, make_dataset())
    meta = {"format": "dlo-shapes", "format_version": FORMAT_VERSION + 1}
    rewrite(path, metadata=np.array(json.dumps(meta)))
    with pytest.raises(ValueError, match=f"format_version {FORMAT_VERSION + 1}"):
        load_shapes(path)


def test_an_npz_of_something_else_is_rejected(tmp_path):
    np.savez(tmp_path / "other.npz", x=np.zeros(3))
    with pytest.raises(ValueError, match="not a shape dataset"):
        load_shapes(tmp_path / "other.npz")


def test_a_file_that_is_not_npz_is_rejected(tmp_path):
    (tmp_path / "text.npz").write_text("hello")
    with pytest.raises(ValueError, match="not a readable .npz"):
        load_shapes(tmp_path / "text.npz")
    np.save(tmp_path / "single.npy", np.zeros(3))
    with pytest.raises(ValueError, match="not an .npz archive"):
        load_shapes(tmp_path / "single.npy")


def test_a_missing_array_is_named(tmp_path):
    path = tmp_path / "d.npz"
    save_shapes(path, make_dataset())
    rewrite(path, transition_after=None)
    with pytest.raises(ValueError, match="lacks the array.*transition_after"):
        load_shapes(path)


def test_an_array_of_the_wrong_dtype_or_shape_is_named(tmp_path):
    path = tmp_path / "d.npz"
    save_shapes(path, make_dataset())
    rewrite(path, shapes=np.zeros((72, 20, 2), dtype=np.float64))
    with pytest.raises(ValueError, match="shapes must be a float32 array"):
        load_shapes(path)
    rewrite(path, shapes=np.zeros((72, 20, 3), dtype=np.float32))
    with pytest.raises(ValueError, match=r"shapes must have shape \(N, n, 2\).*got \(72, 20, 3\)"):
        load_shapes(path)
    rewrite(path, shapes=np.zeros((72, 20, 2), dtype=np.float32),
            shape_transition=np.zeros(5, dtype=np.int64))
    with pytest.raises(ValueError, match="shape_transition must have shape"):
        load_shapes(path)


def test_pickled_object_arrays_are_never_loaded(tmp_path):
    path = tmp_path / "d.npz"
    save_shapes(path, make_dataset())
    rewrite(path, metadata=np.array([{"format": "dlo-shapes"}], dtype=object))
    with pytest.raises(ValueError, match="not a readable .npz"):
        load_shapes(path)


def test_dataset_rejects_transition_indices_out_of_range():
    data = make_dataset()
    bad = data.shape_transition.copy()
    bad[0] = data.num_transitions
    with pytest.raises(ValueError, match="shape_transition must index the 18 transitions"):
        ShapeDataset(**{**data.arrays(), "shape_transition": bad})


def test_split_keeps_whole_episodes_on_one_side():
    data = make_dataset(episodes=10)
    train, val = split(data, validation_fraction=0.2, seed=0)
    assert train.num_shapes + val.num_shapes == data.num_shapes
    assert val.num_shapes == 24  # 2 of 10 equal episodes
    assert not set(train.transition_episode) & set(val.transition_episode)
    assert val.metadata["split"]["part"] == "validation"
    for part in (train, val):  # renumbered transitions still point at the right moves
        np.testing.assert_array_equal(part.transition_before[part.shape_transition[::4]],
                                      part.shapes[::4])


def test_split_is_the_same_for_the_same_seed_and_differs_for_another():
    data = make_dataset(episodes=20)
    a = split(data, 0.25, seed=3)[1]
    b = split(data, 0.25, seed=3)[1]
    c = split(data, 0.25, seed=4)[1]
    np.testing.assert_array_equal(a.transition_episode, b.transition_episode)
    assert set(a.transition_episode) != set(c.transition_episode)


def test_split_rejects_bad_fractions_and_single_episodes():
    with pytest.raises(ValueError, match="validation_fraction must be in"):
        split(make_dataset(), validation_fraction=1.0)
    with pytest.raises(ValueError, match="at least 2 episodes"):
        split(make_dataset(episodes=1))


def test_save_writes_a_real_zip_with_fixed_timestamps(tmp_path):
    save_shapes(tmp_path / "d.npz", make_dataset())
    with zipfile.ZipFile(tmp_path / "d.npz") as zf:
        assert {i.date_time for i in zf.infolist()} == {(1980, 1, 1, 0, 0, 0)}
