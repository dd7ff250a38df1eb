"""Specification of shape dataset collection (dlo_env.dataset.collect)."""

from __future__ import annotations

import numpy as np
import pytest

from dlo_env.dataset.chunks import chunk_plan, parts_dir
from dlo_env.dataset.collect import CollectConfig, collect, collect_chunk
from dlo_env.dataset.shape_file import GRASP_NAMES, load_shapes
from dlo_env.shapes import is_cord_like, on_table, segment_lengths

SMALL = CollectConfig(chunk_size=200)


def _same_arrays(a, b) -> bool:
    return all(np.array_equal(x, y) for x, y in zip(a.arrays().values(), b.arrays().values()))


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """A 500-shape dataset in 3 chunks, collected once for the module."""
    out = tmp_path_factory.mktemp("collect") / "small.npz"
    collect(out, 500, SMALL)
    return out


def test_collect_writes_exactly_the_requested_number_of_shapes(small):
    data = load_shapes(small)
    assert data.shapes.shape == (500, 20, 2)
    assert data.shapes.dtype == np.float32
    assert data.metadata["accepted"] == 500
    assert data.metadata["chunks"] == 3


def test_collected_shapes_pass_the_cord_like_filter_and_lie_on_the_table(small):
    data = load_shapes(small)
    assert is_cord_like(data.shapes, 0.25).all()
    assert on_table(data.shapes).all()


def test_collected_segments_are_within_2_percent_of_rest_length(small):
    data = load_shapes(small)
    rest = 1.0 / 19
    assert np.abs(segment_lengths(data.shapes) / rest - 1.0).max() <= 0.02


def test_collect_removes_the_chunk_folder_after_success(small):
    assert not parts_dir(small).exists()
    assert [p.name for p in small.parent.iterdir()] == ["small.npz"]


def test_metadata_records_settings_and_counts(small):
    meta = load_shapes(small).metadata
    assert meta["seed"] == 0 and meta["workers"] == 1
    assert meta["cosine_threshold"] == 0.25
    assert meta["cord"]["n_points"] == 20
    assert meta["collect"]["chunk_size"] == 200
    assert meta["rejected"]["total"] == meta["rejected"]["cosine"] + meta["rejected"]["stretch"]
    assert meta["wall_time_s"] > 0


def test_shapes_are_recorded_along_moves_not_only_at_their_end(small):
    data = load_shapes(small)
    per_move = np.bincount(data.shape_transition, minlength=data.num_transitions)
    assert per_move.mean() > 3  # 10 substeps ~ 1 cm; moves are 5-40 cm long
    # consecutive shapes of one move are about a centimetre of gripper travel apart
    same = data.shape_transition[1:] == data.shape_transition[:-1]
    step = np.abs(data.shapes[1:] - data.shapes[:-1]).max(axis=(1, 2))[same]
    assert 0.002 < np.median(step) < 0.03


def test_transitions_record_the_ends_moved_and_their_displacement(small):
    data = load_shapes(small)
    assert set(np.unique(data.transition_grasp)) == {0, 1, 2}
    head_held = data.transition_grasp != GRASP_NAMES.index("tail")
    tail_held = data.transition_grasp != GRASP_NAMES.index("head")
    assert (data.transition_displacement[~head_held, 0] == 0).all()
    assert (data.transition_displacement[~tail_held, 1] == 0).all()
    moved_head = data.transition_after[:, 0] - data.transition_before[:, 0]
    moved_tail = data.transition_after[:, -1] - data.transition_before[:, -1]
    np.testing.assert_allclose(moved_head[head_held], data.transition_displacement[head_held, 0],
                               atol=2e-3)
    np.testing.assert_allclose(moved_tail[tail_held], data.transition_displacement[tail_held, 1],
                               atol=2e-3)


def test_moves_of_one_episode_continue_on_the_same_cord(small):
    data = load_shapes(small)
    same = data.transition_episode[1:] == data.transition_episode[:-1]
    np.testing.assert_array_equal(data.transition_before[1:][same],
                                  data.transition_after[:-1][same])
    assert (np.diff(data.transition_episode) >= 0).all()
    assert len(np.unique(data.transition_episode)) > 1


def test_transition_cord_like_flags_match_the_filter(small):
    data = load_shapes(small)
    ok = is_cord_like(data.transition_before) & is_cord_like(data.transition_after)
    assert (ok[data.transition_cord_like]).all()


def test_same_seed_gives_the_same_arrays_and_another_seed_does_not(tmp_path, small):
    again = collect(tmp_path / "again.npz", 500, SMALL)
    assert _same_arrays(again, load_shapes(small))
    other = collect(tmp_path / "other.npz", 500, CollectConfig(seed=1, chunk_size=200))
    assert not np.array_equal(other.shapes, again.shapes)


def _interrupt(accepted: int, rejected: int) -> None:
    raise KeyboardInterrupt


def test_a_smaller_chunk_is_a_prefix_of_a_larger_one():
    short = collect_chunk(SMALL, 3, 50)
    long = collect_chunk(SMALL, 3, 150)
    np.testing.assert_array_equal(short.shapes, long.shapes[:50])
    t = short.num_transitions
    np.testing.assert_array_equal(short.transition_before, long.transition_before[:t])


def test_chunk_plan_covers_the_shapes_in_fixed_size_chunks():
    assert chunk_plan(500, 200) == [(0, 200), (1, 200), (2, 100)]
    assert chunk_plan(400, 200) == [(0, 200), (1, 200)]


def test_a_strict_threshold_rejects_shapes_and_keeps_only_those_passing_it(tmp_path):
    config = CollectConfig(cosine_threshold=0.98, chunk_size=200)
    data = collect(tmp_path / "strict.npz", 150, config)
    assert data.metadata["rejected"]["cosine"] > 0
    assert is_cord_like(data.shapes, 0.98).all()
    assert not is_cord_like(collect_chunk(CollectConfig(chunk_size=200), 0, 150).shapes, 0.98).all()


def test_interrupted_run_keeps_finished_chunks_and_resume_completes_it(tmp_path, small):
    out = tmp_path / "resumed.npz"
    seen = [0]

    def interrupt_in_second_chunk(accepted: int, rejected: int) -> None:
        seen[0] += accepted
        if seen[0] > 250:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        collect(out, 500, SMALL, progress=interrupt_in_second_chunk)
    assert not out.exists()
    kept = sorted(p.name for p in parts_dir(out).glob("chunk-*.npz"))
    assert kept == ["chunk-000000.npz"]

    with pytest.raises(ValueError, match="--resume"):
        collect(out, 500, SMALL)
    reported = []
    data = collect(out, 500, SMALL, resume=True, progress=lambda a, r: reported.append(a))
    assert reported[0] == 200  # the kept chunk is counted first, not made again
    assert data.metadata["chunks_resumed"] == 1
    assert _same_arrays(load_shapes(out), load_shapes(small))
    assert not parts_dir(out).exists()


def test_resume_with_other_settings_is_refused(tmp_path):
    out = tmp_path / "x.npz"
    with pytest.raises(KeyboardInterrupt):
        collect(out, 300, SMALL, progress=_interrupt)
    with pytest.raises(ValueError, match="seed: 0 -> 5"):
        collect(out, 300, CollectConfig(seed=5, chunk_size=200), resume=True)


def test_resume_without_leftovers_starts_afresh(tmp_path):
    data = collect(tmp_path / "fresh.npz", 20, SMALL, resume=True)
    assert data.num_shapes == 20


def test_an_existing_output_is_not_overwritten(small):
    with pytest.raises(ValueError, match="already exists"):
        collect(small, 10, SMALL)


@pytest.mark.parametrize(
    ("name", "num_shapes", "workers", "message"),
    [
        ("a.npz", 0, 1, "num_shapes must be an integer >= 1, got 0"),
        ("a.npz", 10, 0, "workers must be an integer >= 1, got 0"),
        ("a.txt", 10, 1, "out must be a .npz file name"),
    ],
)
def test_bad_arguments_are_rejected_with_clear_messages(tmp_path, name, num_shapes, workers,
                                                        message):
    with pytest.raises(ValueError, match=message):
        collect(tmp_path / name, num_shapes, SMALL, workers=workers)
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("cosine_threshold", 1.5, "cosine_threshold must be in"),
        ("record_every", 0, "record_every must be an integer >= 1"),
        ("chunk_size", 0, "chunk_size must be an integer >= 1"),
        ("seed", -1, "seed must be an integer >= 0"),
        ("min_move", 0.5, "min_move and max_move"),
        ("grasp_weights", (0.0, 0.0, 1.0), "grasp_weights"),
    ],
)
def test_bad_configuration_is_rejected_naming_the_field(field, value, message):
    with pytest.raises(ValueError, match=message):
        CollectConfig(**{field: value})


def test_worker_processes_give_the_same_arrays_as_one_process(tmp_path, small):
    data = collect(tmp_path / "two.npz", 500, SMALL, workers=2)
    assert data.metadata["workers"] == 2
    assert _same_arrays(data, load_shapes(small))


def test_interrupting_workers_saves_the_chunks_they_were_making(tmp_path):
    tiny = CollectConfig(chunk_size=50)
    out = tmp_path / "pool.npz"
    with pytest.raises(KeyboardInterrupt):
        collect(out, 500, tiny, workers=2, progress=_interrupt)
    kept = sorted(p.name for p in parts_dir(out).glob("chunk-*.npz"))
    # running and already queued chunks finish; the rest are cancelled
    assert "chunk-000000.npz" in kept and len(kept) < 10
    assert not list(parts_dir(out).glob(".*tmp*"))
    data = collect(out, 500, tiny, workers=2, resume=True)
    assert data.metadata["chunks_resumed"] == len(kept)
    assert _same_arrays(data, collect(tmp_path / "one.npz", 500, tiny))
