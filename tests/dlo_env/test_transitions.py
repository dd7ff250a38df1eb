"""Specification of one-move transition data (dlo_env.dataset.transitions)."""

from __future__ import annotations

import json
from dataclasses import asdict, replace

import numpy as np
import pytest

from dlo_env.cord import Cord, CordParams, reachable_targets
from dlo_env.dataset import transitions
from dlo_env.dataset.chunks import parts_dir
from dlo_env.dataset.transitions import (
    TransitionCollectConfig,
    collect_transition_chunk,
    collect_transitions,
    load_transition_files,
    load_transitions,
    save_transitions,
    split_transitions,
)
from dlo_env.shapes import error, is_cord_like, on_table, wavy_cord_shape, wide_cord_shape
from dlo_env.tasks import DEFAULT_MAX_STEP, GRASP_ENDS, apply_action, split_move, wait_for_rest

SMALL = TransitionCollectConfig(chunk_size=12)


@pytest.fixture(scope="module")
def chunk():
    return collect_transition_chunk(SMALL, 0, 40)


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    out = tmp_path_factory.mktemp("transitions") / "small.npz"
    collect_transitions(out, 30, SMALL)
    return out


def _same(a, b) -> bool:
    return all(np.array_equal(x, y) for x, y in zip(a.arrays().values(), b.arrays().values()))


def test_a_transition_is_the_simulators_move_carried_out_as_tasks_do_it(chunk):
    names = ("head", "tail", "both")
    for i in range(0, len(chunk), 7):
        grasp = names[chunk.grasp[i]]
        cord = Cord(grasp=grasp)
        cord.reset(chunk.start[i])
        move = np.concatenate([chunk.displacement[i, 0 if e == "head" else 1]
                               for e in GRASP_ENDS[grasp]])
        for action in split_move(move, DEFAULT_MAX_STEP):
            apply_action(cord, action, DEFAULT_MAX_STEP)
        wait_for_rest(cord)
        # From a fresh reset (an episode's first move) the replay is bitwise; later moves
        # continued on a cord whose solver state a reset does not carry: within 0.5 mm.
        assert error(cord.shape, chunk.next[i]) < (1e-6 if chunk.step[i] == 0 else 5e-4)


def test_moves_of_an_episode_follow_each_other_from_the_shape_the_last_left(chunk):
    follow = (chunk.episode[1:] == chunk.episode[:-1])
    assert follow.any()
    assert np.array_equal(chunk.start[1:][follow], chunk.next[:-1][follow])
    assert np.array_equal(chunk.step[1:][follow], chunk.step[:-1][follow] + 1)
    assert (chunk.step[1:][~follow] == 0).all()


def test_the_data_covers_every_grasp_short_and_long_moves_and_stays_on_the_table():
    data = collect_transition_chunk(TransitionCollectConfig(), 3, 150)
    assert set(np.unique(data.grasp)) == {0, 1, 2}
    lengths = np.linalg.norm(data.displacement, axis=-1).max(axis=-1)
    assert lengths.min() < 0.05 and lengths.max() > 0.25
    assert ((lengths >= 0.01 - 1e-6) & (lengths <= 0.35 + 1e-6)).all()
    assert set(np.unique(data.step)) == set(range(5))  # up to four earlier moves
    assert on_table(data.next).all() and on_table(data.start).all()
    assert data.at_rest.mean() > 0.95


def test_moved_is_where_the_grippers_went_and_an_end_not_held_has_no_move(chunk):
    head_only = chunk.grasp == 0
    assert (chunk.displacement[head_only, 1] == 0).all()
    assert (chunk.moved[head_only, 1] == 0).all()
    start = chunk.start[head_only, 0].astype(np.float64)
    reached = reachable_targets((start + chunk.displacement[head_only, 0])[:, None])[:, 0]
    assert np.allclose(chunk.moved[head_only, 0], reached - start, atol=2e-3)


def test_collection_is_deterministic_for_a_seed_whatever_the_workers(tmp_path, small):
    again = collect_transitions(tmp_path / "two.npz", 30, SMALL, workers=2)
    assert _same(again, load_transitions(small))
    other = collect_transitions(tmp_path / "seed1.npz", 30,
                                TransitionCollectConfig(seed=1, chunk_size=12))
    assert not np.array_equal(other.start, again.start)


def test_a_killed_run_resumes_without_losing_or_repeating_a_transition(tmp_path, small):
    out = tmp_path / "resumed.npz"
    seen = [0]

    def interrupt_in_second_chunk(done: int, rejected: int) -> None:
        seen[0] += done
        if seen[0] > 15:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        collect_transitions(out, 30, SMALL, progress=interrupt_in_second_chunk)
    assert sorted(p.name for p in parts_dir(out).glob("chunk-*.npz")) == ["chunk-000000.npz"]
    with pytest.raises(ValueError, match="--resume"):
        collect_transitions(out, 30, SMALL)
    with pytest.raises(ValueError, match="seed: 0 -> 4"):
        collect_transitions(out, 30, TransitionCollectConfig(seed=4, chunk_size=12), resume=True)
    # A run from before a setting existed (its manifest lacks it) resumes: it had the default.
    manifest = parts_dir(out) / "manifest.json"
    saved = json.loads(manifest.read_text())
    del saved["collect"]["wavy_fraction"]
    manifest.write_text(json.dumps(saved))
    with pytest.raises(ValueError, match=r"wavy_fraction: 0.0 -> 0.5"):
        collect_transitions(out, 30, replace(SMALL, wavy_fraction=0.5), resume=True)
    data = collect_transitions(out, 30, SMALL, resume=True)
    assert data.metadata["chunks_resumed"] == 1 and data.metadata["transitions_resumed"] == 12
    assert _same(data, load_transitions(small))
    assert not parts_dir(out).exists()


def test_files_round_trip_and_a_foreign_or_corrupt_file_gets_one_line(tmp_path, small):
    data = load_transitions(small)
    copy = save_transitions(tmp_path / "copy.npz", data)
    assert _same(load_transitions(copy), data)
    assert copy.read_bytes() == small.read_bytes()  # byte-reproducible
    corrupt = tmp_path / "corrupt.npz"
    corrupt.write_bytes(small.read_bytes()[:200])
    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, shapes=np.zeros((3, 20, 2), np.float32))
    for path, message in ((corrupt, "not a readable .npz transition dataset"),
                          (foreign, "not a transition dataset: no 'metadata'")):
        with pytest.raises(ValueError, match=message) as info:
            load_transitions(path)
        assert "\n" not in str(info.value)
    with pytest.raises(FileNotFoundError, match="dlo collect transitions"):
        load_transitions(tmp_path / "missing.npz")


def test_several_files_load_as_one_dataset_recording_what_each_file_held(tmp_path, small):
    other = tmp_path / "other.npz"
    collect_transitions(other, 14, TransitionCollectConfig(chunk_size=7, seed=5,
                                                            wide_fraction=0.5))
    data = load_transition_files([small, other])
    a, b = load_transitions(small), load_transitions(other)
    assert len(data) == len(a) + len(b) == 44
    assert np.array_equal(data.start[len(a):], b.start)
    assert set(data.episode[:len(a)]).isdisjoint(data.episode[len(a):])  # episodes stay apart
    assert data.metadata["files"] == [str(small), str(other)]
    first, second = data.metadata["sources"]
    assert (first["transitions"], second["transitions"]) == (30, 14)
    assert (first["collect"]["seed"], second["collect"]["seed"]) == (0, 5)
    assert second["collect"]["wide_fraction"] == 0.5
    assert first["digest"] != second["digest"] and len(first["digest"]) == 16
    assert "seed" not in data.metadata["collect"]  # the files differ in it
    assert data.metadata["collect"]["max_step"] == first["collect"]["max_step"]  # shared
    assert "num_transitions" not in data.metadata  # no one file's counts for the whole
    copy = tmp_path / "copy.npz"  # the digest is of the content, not the name
    copy.write_bytes(small.read_bytes())
    alone = load_transition_files(str(copy))  # one path
    assert alone.metadata["sources"][0]["digest"] == first["digest"] and len(alone) == 30
    with pytest.raises(ValueError, match="copy.npz' holds the same transitions as .*small.npz'"):
        load_transition_files([small, other, copy])


def test_files_of_another_cord_or_none_at_all_are_refused_in_one_line(tmp_path, small):
    data = load_transitions(small)
    cord = {**data.metadata["cord"], "friction": 0.9}
    foreign = save_transitions(tmp_path / "foreign-cord.npz", transitions.TransitionDataset(
        **data.arrays(), metadata={**data.metadata, "cord": cord}))
    with pytest.raises(ValueError, match="foreign-cord.npz' was collected with another cord"):
        load_transition_files([small, foreign])
    with pytest.raises(ValueError, match="paths must name at least one transition file"):
        load_transition_files([])


@pytest.mark.parametrize("rim_fraction", [0.1, 0.75])
def test_a_share_rim_fraction_of_the_moves_heads_for_the_nearest_edge(rim_fraction):
    config = TransitionCollectConfig(rim_fraction=rim_fraction, push_fraction=0.0)
    cord = Cord(CordParams(), grasp="head")
    cord.reset(np.stack([np.linspace(-0.5, 0.5, 20), np.full(20, 0.6)], axis=1))
    head = cord.gripper_positions()["head"]
    axis = int(np.argmax(np.abs(head)))
    normal = np.zeros(2)
    normal[axis] = np.sign(head[axis])
    rng = np.random.default_rng(0)
    moves = np.array([transitions._draw_move(rng, cord, config) for _ in range(2000)])
    cosine = moves @ normal / np.linalg.norm(moves, axis=1)
    # Aimed ones are within 45 degrees of the edge's normal; a quarter of the others too.
    within = np.mean(cosine > np.cos(np.pi / 4))
    assert abs(within - (rim_fraction + 0.25 * (1 - rim_fraction))) < 0.03


def test_split_keeps_each_episode_on_one_side(small):
    train, validation = split_transitions(load_transitions(small), 0.3, seed=0)
    assert len(train) + len(validation) == 30
    assert not set(train.episode) & set(validation.episode)


@pytest.mark.parametrize(("field", "value", "message"), [
    ("moves_per_episode", 0, "moves_per_episode must be an int >= 1"),
    ("min_move", 0.5, "min_move and max_move"),
    ("grasp_weights", (0.0, 0.0, 0.0), "grasp_weights"),
    ("push_fraction", 0.95, "push_fraction and rim_fraction"),
    ("log_fraction", 2.0, "log_fraction must be in"),
    ("wide_fraction", -0.1, "wide_fraction must be in"),
    ("wavy_fraction", 1.5, "wavy_fraction must be in"),
    ("wavy_fraction", 0.6, "wide_fraction and wavy_fraction must have a sum <= 1"),
])
def test_bad_configuration_is_rejected_naming_the_field(field, value, message):
    with pytest.raises(ValueError, match=message):
        TransitionCollectConfig(**{"wide_fraction": 0.5, field: value})


def test_reachable_targets_is_the_rule_the_cord_follows():
    params = CordParams()
    cord = Cord(params, grasp="both")
    x = -0.5 + params.segment * np.arange(params.n_points)
    cord.reset(np.stack([x, np.zeros_like(x)], axis=1))
    start = np.stack(list(cord.gripper_positions().values()))
    wanted = start + np.array([[-0.9, 0.2], [0.8, 0.3]])  # off the table and too far apart
    expected = reachable_targets(wanted, params)
    cord.move(head=wanted[0] - start[0], tail=wanted[1] - start[1])
    got = np.stack(list(cord.gripper_positions().values()))
    assert np.allclose(got, expected, atol=1e-9)
    assert np.linalg.norm(expected[1] - expected[0]) <= params.max_span * params.length + 1e-9


def test_env_steps_count_every_action_and_settle_of_the_moves():
    from dlo_env.dataset.transitions import TransitionCollectConfig, collect_transition_chunk
    from dlo_env.tasks import DEFAULT_MAX_STEP, split_move

    data = collect_transition_chunk(TransitionCollectConfig(seed=5), 0, 12)
    by_hand = 0
    for d, held, settle in zip(data.displacement, data.grasp, data.settle):
        ends = {0: [0], 1: [1], 2: [0, 1]}[int(held)]
        by_hand += len(split_move(d[ends].reshape(-1), DEFAULT_MAX_STEP)) + int(settle)
    assert data.env_steps() == by_hand


def test_wide_starts_are_drawn_by_wide_cord_shape_and_settled_as_every_start(chunk, monkeypatch):
    calls = []

    def counted(*args, **kwargs):
        calls.append(1)
        return wide_cord_shape(*args, **kwargs)

    monkeypatch.setattr(transitions, "wide_cord_shape", counted)
    wide = collect_transition_chunk(
        TransitionCollectConfig(chunk_size=12, wide_fraction=1.0, grasp_weights=(0, 0, 1)), 0, 10)
    first = wide.start[wide.step == 0]
    assert len(first) == 2 and len(calls) >= 2  # every start (a rejected draw is drawn again)
    assert is_cord_like(first).all() and on_table(wide.next).all()
    span = CordParams().max_span * CordParams().length
    assert (np.linalg.norm(first[:, -1] - first[:, 0], axis=-1) < span).all()
    # At wide_fraction 0 choosing the start family draws no random number: the data is what
    # the code made before the option existed (points of its first and last shape then).
    np.testing.assert_allclose(chunk.start[0, [0, 7, 19]], [
        [0.1339544, 0.01992647], [0.20646718, -0.3243924], [-0.36117348, -0.37432355]], atol=1e-6)
    np.testing.assert_allclose(chunk.next[-1, [0, 7, 19]], [
        [-0.53157717, 0.11815619], [-0.19679147, -0.00902746], [0.07396714, 0.51108027]],
        atol=1e-6)


def test_wavy_starts_are_drawn_by_wavy_cord_shape_and_leave_wide_files_as_they_were(monkeypatch):
    calls = []

    def counted(*args, **kwargs):
        calls.append(1)
        return wavy_cord_shape(*args, **kwargs)

    monkeypatch.setattr(transitions, "wavy_cord_shape", counted)
    wavy = collect_transition_chunk(
        TransitionCollectConfig(chunk_size=12, wavy_fraction=1.0, grasp_weights=(0, 0, 1)), 0, 10)
    first = wavy.start[wavy.step == 0]
    assert len(first) == 2 and len(calls) >= 2
    assert is_cord_like(first).all() and on_table(wavy.next).all()
    monkeypatch.undo()
    # With wavy_fraction 0 a file with wide starts is what the code made before the option
    # existed (points of the first start, wide, of the second episode's start, random, and of
    # the last shape then).
    wide = collect_transition_chunk(TransitionCollectConfig(
        seed=0, chunk_size=12, wide_fraction=0.5, grasp_weights=(0, 0, 1)), 0, 10)
    np.testing.assert_allclose(wide.start[0, [0, 7, 19]], [
        [-0.38346046, 0.80898452], [-0.57982266, 0.55125177], [-0.02628970, 0.58960652]],
        atol=1e-6)
    np.testing.assert_allclose(wide.start[wide.step == 0][1][[0, 7, 19]], [
        [0.50239307, -0.34108874], [0.13731155, -0.36989161], [0.04216677, -0.87045270]],
        atol=1e-6)
    np.testing.assert_allclose(wide.next[-1, [0, 7, 19]], [
        [0.00594791, -0.91015756], [-0.08598527, -0.57222182], [-0.18782043, -0.98000002]],
        atol=1e-6)


@pytest.mark.parametrize(("wide", "wavy"), [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.3, 0.3)])
def test_the_start_family_takes_one_draw_and_none_without_the_options(wide, wavy):
    config = TransitionCollectConfig(wide_fraction=wide, wavy_fraction=wavy)
    rng, twin = np.random.default_rng(3), np.random.default_rng(3)
    picked = [transitions._start_family(rng, config) for _ in range(3000)]
    if wide + wavy == 0:  # the random stream is untouched: files from before the options
        assert rng.bit_generator.state == twin.bit_generator.state
    else:
        twin.uniform(size=3000)
        assert rng.bit_generator.state == twin.bit_generator.state
    shares = [np.mean([p is f for p in picked]) for f in (
        transitions.wide_cord_shape, transitions.wavy_cord_shape, transitions.random_cord_shape)]
    np.testing.assert_allclose(shares, [wide, wavy, 1 - wide - wavy], atol=0.03)


# ---------------------------------------------------------------- cords that differ
RANGES = {"bending_stiffness": (0.003, 0.03), "friction": (0.2, 0.6), "length": (0.8, 1.2)}


def test_collecting_over_cords_records_each_episodes_cord():
    config = TransitionCollectConfig(seed=3, randomize=RANGES, chunk_size=30)
    data = collect_transition_chunk(config, 0, 30)
    again = collect_transition_chunk(config, 0, 30)
    assert np.array_equal(data.params, again.params) and np.array_equal(data.next, again.next)
    columns = dict(zip(transitions.PARAM_COLUMNS, data.params.T))
    for name, (low, high) in RANGES.items():
        assert (columns[name] >= np.float32(low)).all() and (columns[name] <= high).all()
    assert (columns["mass"] == np.float32(CordParams().mass)).all()  # not randomised
    for episode in np.unique(data.episode):
        rows = data.params[data.episode == episode]
        assert (rows == rows[0]).all()  # one cord per episode
    assert len(np.unique(data.params[:, 0])) == len(np.unique(data.episode)) > 1
    # Each start has the length of its own cord.
    lengths = np.linalg.norm(np.diff(data.start, axis=1), axis=-1).sum(axis=1)
    np.testing.assert_allclose(lengths, columns["length"], rtol=0.02)


def test_a_version_1_file_loads_with_the_cord_of_its_metadata(tmp_path, chunk):
    from dlo_env.dataset.npz_file import save_npz

    heavy = CordParams(mass=0.2)
    arrays = {k: v for k, v in chunk.arrays().items() if k not in ("params", "pegs", "peg_count")}
    path = save_npz(tmp_path / "v1.npz", arrays, {"cord": asdict(heavy)}, "dlo-transitions", 1)
    data = load_transitions(path)
    assert data.params.shape == (len(chunk), 4)
    assert np.allclose(data.params[:, transitions.PARAM_COLUMNS.index("mass")], 0.2)


def test_a_transition_model_refuses_data_of_several_cords(tmp_path):
    from latent_model.transition_training import train_transition_model

    data = collect_transition_chunk(TransitionCollectConfig(seed=1, randomize=RANGES), 0, 12)
    with pytest.raises(ValueError, match="several cords"):
        train_transition_model(data, tmp_path / "model")


@pytest.mark.parametrize(("randomize", "match"), [
    ({"mass": (0.01, 0.3)}, r"must lie within"),
    ({"colour": (0.1, 0.2)}, r"keys must be some of"),
])
def test_bad_ranges_of_a_collection_are_one_line_errors(randomize, match):
    with pytest.raises(ValueError, match=match):
        TransitionCollectConfig(randomize=randomize)


def test_resaving_a_version_1_file_writes_the_current_version(tmp_path, chunk):
    from dlo_env.dataset.npz_file import save_npz

    arrays = {k: v for k, v in chunk.arrays().items() if k not in ("params", "pegs", "peg_count")}
    old = save_npz(tmp_path / "v1.npz", arrays, {"cord": asdict(CordParams())},
                   "dlo-transitions", 1)
    again = load_transitions(save_transitions(tmp_path / "v3.npz", load_transitions(old)))
    assert again.metadata["format_version"] == transitions.FORMAT_VERSION == 3
    assert again.params.shape == (len(chunk), 4) and again.pegs.shape == (len(chunk), 0, 2)
    assert not again.peg_count.any()


def test_a_version_2_file_without_pegs_loads_and_one_missing_them_at_version_3_is_refused(
        tmp_path, chunk):
    from dlo_env.dataset.npz_file import save_npz

    arrays = {k: v for k, v in chunk.arrays().items() if k not in ("pegs", "peg_count")}
    v2 = save_npz(tmp_path / "v2.npz", arrays, {"cord": asdict(CordParams())},
                  "dlo-transitions", 2)
    assert load_transitions(v2).pegs.shape == (len(chunk), 0, 2)
    v3 = save_npz(tmp_path / "v3.npz", arrays, {"cord": asdict(CordParams())},
                  "dlo-transitions", 3)
    with pytest.raises(ValueError, match="lacks the array pegs"):
        load_transitions(v3)


def test_collecting_with_pegs_records_them_and_the_moves_run_around_them(chunk):
    from dlo_env.cord import LINK_RADIUS, peg_clearance

    config = replace(SMALL, max_pegs=3)
    data = collect_transition_chunk(config, 0, 40)
    assert data.pegs.shape == (40, 3, 2) and set(data.peg_count.tolist()) <= {0, 1, 2, 3}
    assert data.peg_count.any()
    for i in range(len(data)):
        pegs = data.peg_list(i)
        assert not data.pegs[i, len(pegs):].any()
        if len(pegs):  # no point in a peg, the centre line about a link radius off its surface
            for shape in (data.start[i], data.next[i]):
                assert peg_clearance(shape, pegs) > LINK_RADIUS - 1e-3
        # One cord with the same pegs carries the move out to the same shape.
        cord = Cord(grasp=transitions.GRASP_NAMES[data.grasp[i]], pegs=pegs)
        cord.reset(data.start[i])
        ends = GRASP_ENDS[cord.grasp]
        move = np.concatenate([data.displacement[i, 0 if e == "head" else 1] for e in ends])
        for action in split_move(move, DEFAULT_MAX_STEP):
            apply_action(cord, action, DEFAULT_MAX_STEP)
        wait_for_rest(cord)
        if data.step[i] == 0:  # a fresh start: the state is the shape (float32-rounded) alone
            np.testing.assert_allclose(cord.shape, data.next[i], atol=1e-6)
    assert _same(data, collect_transition_chunk(config, 0, 40))
    # Without pegs the data is what it was: no draws are spent on pegs.
    assert _same(chunk, collect_transition_chunk(SMALL, 0, 40))
    # Files with and without pegs load as one, the slots padded.
    both = transitions.TransitionDataset.concatenate([chunk, data])
    assert both.pegs.shape == (80, 3, 2) and not both.peg_count[:40].any()
    with pytest.raises(ValueError, match="max_pegs must be an int"):
        TransitionCollectConfig(max_pegs=-1)


def test_a_transition_model_refuses_data_around_pegs(tmp_path):
    from latent_model.transition_training import train_transition_model

    data = collect_transition_chunk(replace(SMALL, max_pegs=2, seed=3), 0, 15)
    assert data.peg_count.any()
    with pytest.raises(ValueError, match="does not see pegs"):
        train_transition_model(data, tmp_path / "model")


def test_one_cord_refuses_several_cords_and_a_part_of_a_randomised_file():
    data = collect_transition_chunk(TransitionCollectConfig(seed=2, randomize=RANGES), 0, 20)
    with pytest.raises(ValueError, match="several cords"):
        data.one_cord()
    part = data.subset(data.episode == data.episode[0])
    with pytest.raises(ValueError, match="another cord than its metadata"):
        part.one_cord()
    plain = collect_transition_chunk(SMALL, 0, 5)
    assert plain.one_cord() == CordParams()
