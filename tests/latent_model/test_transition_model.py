"""Specification of the transition model (latent_model.transition_model and its training)."""

from __future__ import annotations

from dataclasses import asdict, replace

import numpy as np
import pytest
import torch

from dlo_env.cord import Cord, CordParams, reachable_targets
from dlo_env.dataset.transitions import TransitionCollectConfig, collect_transition_chunk
from dlo_env.shapes import error, random_cord_shape
from dlo_env.tasks import DEFAULT_MAX_STEP, apply_action, split_move
from latent_model import TransitionModel
from latent_model.transition_metrics import transition_report, write_report
from latent_model.transition_model import RIM_TARGETS, TransitionModelConfig
from latent_model.transition_training import (
    CURVE_FILE,
    TransitionTrainConfig,
    as_tensors,
    chain_starts,
    fingerprint,
    one_move_loss,
    paired_moves,
    train_transition_model,
)

TINY = TransitionModelConfig(width=32, depth=2, members=3, rim_reach=0.15)


@pytest.fixture(scope="module")
def data():
    return collect_transition_chunk(TransitionCollectConfig(seed=3), 0, 60)


@pytest.fixture(scope="module")
def model() -> TransitionModel:
    torch.manual_seed(0)
    m = TransitionModel(TINY, device="cpu")
    with torch.no_grad():  # a random but not tiny output, so equivariance is really tested
        m.net.weights[-1].mul_(30.0)
    return m.eval()


def _shapes(count: int, seed: int = 0, margin: float = 0.4) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.stack([random_cord_shape(rng, margin=margin) for _ in range(count)])


def _turn(points: np.ndarray, angle: float, shift: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return (points @ np.array([[c, s], [-s, c]], dtype=np.float32) + shift).astype(np.float32)


@pytest.mark.parametrize("end", ["head", "tail", "both"])
def test_rotating_and_shifting_the_input_rotates_and_shifts_the_output(model, end):
    # Away from the rim (farther than rim_reach from every edge), as the physics is.
    shapes = _shapes(16, margin=0.5)
    rng = np.random.default_rng(1)
    width = 4 if end == "both" else 2
    d = rng.uniform(-0.1, 0.1, size=(16, width)).astype(np.float32)
    pred = model.predict(shapes, end, d)
    for angle, shift in ((0.7, (0.05, -0.05)), (-2.5, (-0.05, 0.03)), (np.pi, (0.0, 0.0))):
        shift = np.array(shift, dtype=np.float32)
        turned = model.predict(_turn(shapes, angle, shift), end,
                               _turn(d.reshape(16, -1, 2), angle, 0 * shift).reshape(16, -1))
        assert np.abs(turned - _turn(pred, angle, shift)).max() < 1e-5
    assert np.abs(pred - shapes).max() > 0.01  # the model does move the cord


@pytest.mark.parametrize("end", ["head", "tail", "both"])
def test_a_mirrored_input_gives_the_mirrored_output(model, end):
    # Mirroring across the table's axis x = 0 maps the table onto itself: it holds at the rim too.
    shapes = _shapes(32, seed=4, margin=0.05)
    rng = np.random.default_rng(2)
    d = rng.uniform(-0.2, 0.2, size=(32, 4 if end == "both" else 2)).astype(np.float32)
    flip = np.array([-1.0, 1.0], dtype=np.float32)

    def gap(m):
        pred = m.predict(shapes, end, d)
        mirrored = m.predict(shapes * flip, end, (d.reshape(32, -1, 2) * flip).reshape(32, -1))
        return np.abs(mirrored - pred * flip).max()

    assert gap(model) < 1e-5


def test_members_with_their_own_starts_mirror_each_start_on_its_own(model):
    # Chains roll out one start per member: each member must see its own start mirrored or
    # not, as it would alone.
    shapes = _shapes(6, seed=7)
    rng = np.random.default_rng(3)
    starts = torch.from_numpy(np.stack([shapes[rng.permutation(6)] for _ in range(3)]))
    grasp = torch.tensor([0, 1, 2, 0, 1, 2])
    moves = torch.from_numpy(rng.uniform(-0.1, 0.1, (6, 2, 2)).astype(np.float32))
    moves[grasp == 0, 1] = 0
    moves[grasp == 1, 0] = 0
    with torch.no_grad():
        together = model(starts, grasp, moves)
        for k in range(3):
            assert torch.allclose(together[k], model(starts[k], grasp, moves)[k], atol=1e-6)


def test_near_the_rim_the_model_sees_the_rim(model):
    shapes = _shapes(4, seed=9, margin=0.5)
    d = np.full((4, 2), 0.05, dtype=np.float32)
    shift = np.array([0.45, 0.0], dtype=np.float32)  # some points now within rim_reach
    moved = model.predict(shapes + shift, "head", d)
    assert np.abs(moved - (model.predict(shapes, "head", d) + shift)).max() > 1e-4


class _RimRecorder(TransitionModel):
    """Keeps the rim vectors the network was given."""

    def predict_points(self, points, lead, other, both, rim, members_batch, members=None,
                       net=None, cord=None):
        self.rim = rim.clone()
        return super().predict_points(points, lead, other, both, rim, members_batch, members,
                                      net, cord)


@pytest.mark.parametrize("lead", ["head", "tail"])
def test_the_network_sees_the_rim_at_both_held_ends_targets(lead):
    from latent_model.move_frame import handedness, rim_vectors, to_frame

    config = TransitionModelConfig(width=16, depth=1, members=2, rim_reach=0.35)
    model = _RimRecorder(config, device="cpu").eval()
    # A bent cord (ends 0.8 m apart) whose other end moves less than the leading one, onto
    # the rim; both targets are within the span, so the moves are not clipped.
    t = np.linspace(0.0, 1.0, 20)
    shape = np.stack([0.8 * t, 0.2 * np.sin(np.pi * t)], axis=1).astype(np.float32)
    lead_move, other_move = np.array([0.3, 0.1]), np.array([0.15, 0.05])
    if lead == "head":
        d = np.concatenate([lead_move, other_move])
    else:  # the same move of the reversed cord: the tail leads, the head is the other end
        shape, d = shape[::-1].copy(), np.concatenate([other_move, lead_move])
    model.predict(shape, "both", d.astype(np.float32))
    target = torch.tensor([[0.95, 0.05]], dtype=torch.float32)  # 0.8 + 0.15, 0 + 0.05
    near = rim_vectors(target, 1.0, 0.35)[0]
    assert float(near.norm()) > 0.5  # the other end's target is near the rim
    c, s_ = lead_move / np.linalg.norm(lead_move)
    expected = torch.tensor([c * near[0] + s_ * near[1], -s_ * near[0] + c * near[1]])
    # In the move's frame, mirrored with the cord when it lies right of the move's line.
    points = to_frame(torch.from_numpy(shape[None]), torch.tensor([2]),
                      torch.from_numpy(d.astype(np.float32).reshape(1, 2, 2)))[0]
    expected = expected.float() * handedness(points)[0]
    assert torch.allclose(model.rim[0, -1], expected, atol=1e-5)
    assert np.abs(model.rim[0, -2].numpy()).max() == 0.0  # the lead's target is far from it


def test_a_tail_move_is_a_head_move_of_the_reversed_cord(model):
    shapes = _shapes(8, seed=2)
    d = np.random.default_rng(2).uniform(-0.1, 0.1, size=(8, 2)).astype(np.float32)
    tail = model.predict(shapes, "tail", d)
    head = model.predict(shapes[:, ::-1], "head", d)[:, ::-1]
    assert np.abs(tail - head).max() < 1e-6


def test_the_held_ends_go_exactly_where_the_simulators_grippers_go(model):
    shapes = _shapes(4, seed=3)
    d = np.random.default_rng(3).uniform(-0.3, 0.3, size=(4, 4)).astype(np.float32)
    d[0] = [-0.3, 0.0, 0.3, 0.0]  # pulls the ends apart beyond the span: the rule clips it
    for end, width in (("both", 4), ("tail", 2)):
        move = d[:, :width] if end == "both" else d[:, 2:]
        pred = model.predict(shapes, end, move)
        for shape, m, p in zip(shapes, move, pred):
            cord = Cord(grasp=end)
            cord.reset(shape)
            for action in split_move(m, DEFAULT_MAX_STEP):
                apply_action(cord, action, DEFAULT_MAX_STEP)
            grips = cord.gripper_positions()
            assert np.allclose(p[-1], grips["tail"], atol=1e-5)
            if end == "both":
                assert np.allclose(p[0], grips["head"], atol=1e-5)


@pytest.mark.parametrize("end", ["head", "both"])
def test_reachable_moves_walk_only_the_moves_the_rule_clips_and_agree_with_every_action(
        model, end):
    # Against the rule applied after every split_move action: starts at the rim and inside,
    # moves from tiny to far beyond the table and the span, in every direction.
    rng = np.random.default_rng(21)
    shapes = _shapes(300, seed=21, margin=0.02)
    width = 4 if end == "both" else 2
    d = (rng.uniform(-1, 1, size=(300, width)) * rng.choice([0.02, 0.3, 1.5], size=(300, 1)))
    ends = [0, -1] if end == "both" else [0]
    reach = model.reachable_moves(shapes, end, d)[:, [0, 1] if end == "both" else [0]]
    for shape, move, got in zip(shapes, d, reach):
        pos = shape[ends].astype(np.float64)
        for action in split_move(move, DEFAULT_MAX_STEP):
            pos = reachable_targets(pos + action.reshape(-1, 2) * DEFAULT_MAX_STEP)
        assert np.allclose(got, pos - shape[ends], atol=1e-6)
    assert (np.abs(reach - d.reshape(300, -1, 2)).max(axis=(1, 2)) > 1e-3).mean() > 0.2


def test_a_held_end_starting_beyond_the_grippers_reach_moves_as_the_simulators_does(model):
    # The grippers stay rim_margin inside the edge; a cord may lie closer. From there the
    # clipping goes action by action, as the environment's actions do.
    shapes = _shapes(6, seed=12)
    shapes = shapes - shapes[:, :1] + np.array([0.995, 0.0], dtype=np.float32)  # head at the rim
    shapes[:, :, 0] -= np.maximum(shapes[:, :, 0].max(axis=1, keepdims=True) - 0.999, 0.0)
    assert (shapes[:, 0, 0] > 1.0 - model.cord_params.rim_margin).any()
    d = np.random.default_rng(12).uniform(-0.3, 0.3, size=(6, 2)).astype(np.float32)
    d[0] = [-0.01, 0.2]  # barely away from the edge: the first actions are clipped
    d[1] = [0.1, 0.0]  # into the edge
    pred = model.predict(shapes, "head", d)
    for shape, m, p in zip(shapes, d, pred):
        cord = Cord(grasp="head")
        cord.reset(shape)
        for action in split_move(m, DEFAULT_MAX_STEP):
            apply_action(cord, action, DEFAULT_MAX_STEP)
        assert np.allclose(p[0], cord.gripper_positions()["head"], atol=1e-5)


def test_no_move_leaves_the_cord_where_it_lies_and_targets_are_clipped_like_the_cord(model):
    shapes = _shapes(4, seed=4)
    assert np.array_equal(model.predict(shapes, "head", np.zeros((4, 2))), shapes)
    off = model.predict(shapes, "head", np.tile([5.0, 0.0], (4, 1)))
    assert np.allclose(off[:, 0, 0], 1.0 - model.cord_params.rim_margin, atol=1e-6)
    assert (np.abs(off) <= 1.0).all()


def test_predictions_never_leave_the_table():
    m = TransitionModel(TINY, device="cpu")
    with torch.no_grad():
        m.net.biases[-1].fill_(50.0)  # a model that would throw every point off the table
    shapes = _shapes(6, seed=5, margin=0.1)
    pred = m.predict(shapes, "head", np.full((6, 2), 0.05))
    assert np.abs(pred).max() <= 1.0


def test_flat_shapes_as_observations_hold_them_are_accepted(model):
    shapes = _shapes(4, seed=8)
    d = np.full((4, 2), 0.05, dtype=np.float32)
    expected = model.predict(shapes, "head", d)
    np.testing.assert_array_equal(model.predict(shapes.reshape(4, -1), "head", d), expected)
    np.testing.assert_array_equal(model.predict(shapes[1].reshape(-1), "head", d[1]), expected[1])
    with pytest.raises(ValueError, match=r"shapes must have shape \(20, 2\), \(40,\)"):
        model.predict(shapes.reshape(4, -1)[:, :38], "head", d)


def test_grasp_names_the_moving_ends_and_end_is_its_deprecated_alias(model):
    shapes = _shapes(3, seed=9)
    d = np.full((3, 2), 0.05, dtype=np.float32)
    expected = model.predict(shapes, grasp="tail", displacement=d)
    with pytest.warns(DeprecationWarning, match="use grasp="):
        np.testing.assert_array_equal(model.predict(shapes, end="tail", displacement=d), expected)
    with pytest.raises(ValueError, match="not both"):
        model.predict(shapes, "tail", d, end="tail")
    with pytest.raises(ValueError, match="grasp must be one of"):
        model.predict(shapes, "middle", d)


def test_single_shapes_batches_and_the_ensemble_spread(model):
    shapes = _shapes(5, seed=6)
    d = np.full((5, 2), 0.05, dtype=np.float32)
    batch, spread = model.predict(shapes, "head", d, return_std=True)
    assert batch.shape == (5, 20, 2) and batch.dtype == np.float32
    assert spread.shape == (5,) and (spread > 0).all()
    one, one_spread = model.predict(shapes[0], "head", d[0], return_std=True)
    assert one.shape == (20, 2) and np.ndim(one_spread) == 0
    assert np.allclose(one, batch[0], atol=1e-6)


@pytest.mark.parametrize("end", ["head", "tail", "both"])
def test_predictions_have_rest_length_segments_unless_asked_for_the_raw_mean(model, end):
    shapes = _shapes(8, seed=10)
    d = np.random.default_rng(10).uniform(-0.1, 0.1, (8, 4 if end == "both" else 2))
    d = d.astype(np.float32)
    raw = model.predict(shapes, end, d, inextensible=False)
    pred = model.predict(shapes, end, d)
    rest = 1.0 / 19

    def deviation(s):
        return np.median(np.abs(np.linalg.norm(np.diff(s, axis=1), axis=-1) - rest)) / rest

    assert deviation(raw) > 0.05 and deviation(pred) < 0.2 * deviation(raw)
    held = {"head": [0], "tail": [-1], "both": [0, -1]}[end]
    assert np.array_equal(pred[:, held], raw[:, held])  # the held ends are where they were


def test_the_first_members_alone_are_the_first_members_of_the_ensemble(model):
    shapes = _shapes(4, seed=8)
    d = np.full((4, 2), -0.07, dtype=np.float32)
    with torch.no_grad():
        first = model.net.weights[0][:1].clone(), model.net.biases[0][:1].clone()
    solo = TransitionModel(TransitionModelConfig(**{**TINY.__dict__, "members": 1}), device="cpu")
    with torch.no_grad():
        for dst, src in zip(list(solo.net.weights) + list(solo.net.biases),
                            list(model.net.weights) + list(model.net.biases)):
            dst.copy_(src[:1])
    assert torch.equal(first[0], solo.net.weights[0]) and torch.equal(first[1], solo.net.biases[0])
    one = model.predict(shapes, "tail", d, members=np.int64(1))
    assert np.allclose(one, solo.predict(shapes, "tail", d), atol=1e-6)
    assert not np.allclose(one, model.predict(shapes, "tail", d), atol=1e-4)
    two, spread = model.predict(shapes, "tail", d, return_std=True, members=2)
    assert (spread > 0).all()
    with pytest.raises(ValueError, match="return_std needs members >= 2"):
        model.predict(shapes, "tail", d, return_std=True, members=1)
    with pytest.raises(ValueError, match="return_std needs members >= 2"):
        solo.predict(shapes, "tail", d, return_std=True)  # a one-network ensemble
    for bad in (0, 4, 1.5, True):
        with pytest.raises(ValueError, match="members must be an int in 1..3"):
            model.predict(shapes, "tail", d, members=bad)


@pytest.mark.parametrize(("args", "message"), [
    ((np.zeros((3, 19, 2)), "head", np.zeros((3, 2))), "shapes must have shape"),
    ((np.zeros((3, 20, 2)), "middle", np.zeros((3, 2))), "grasp must be one of"),
    ((np.zeros((3, 20, 2)), "both", np.zeros((3, 2))), "displacement must have shape"),
    ((np.zeros((3, 20, 2)), "head", np.full((3, 2), np.nan)), "must be finite"),
    (("abc", "head", np.zeros(2)), "shapes must be numbers"),
    ((np.zeros((20, 2)), "head", "xy"), "displacement must be numbers"),
])
def test_bad_input_gets_one_line_naming_the_argument(model, args, message):
    with pytest.raises(ValueError, match=message) as info:
        model.predict(*args)
    assert "\n" not in str(info.value)


def test_save_and_load_round_trip_and_a_corrupt_file_is_refused(model, tmp_path):
    path = model.save(tmp_path)
    loaded = TransitionModel.load(tmp_path, device="cpu")
    assert loaded.config == model.config
    shapes = _shapes(4, seed=7)
    d = np.full((4, 2), 0.08, dtype=np.float32)
    # stored in float16: predictions agree to well under a tenth of a millimetre
    assert np.abs(loaded.predict(shapes, "head", d) - model.predict(shapes, "head", d)).max() < 5e-5
    path.write_bytes(path.read_bytes()[:100])
    with pytest.raises(ValueError, match="not a readable torch checkpoint"):
        TransitionModel.load(path)
    with pytest.raises(FileNotFoundError):
        TransitionModel.load(tmp_path / "missing.pt")


def test_a_file_from_before_rim_targets_or_with_a_retired_setting_is_refused_in_one_line():
    old = TransitionModel(TransitionModelConfig(width=16, depth=1, members=2), device="cpu")
    state = old.state()
    assert {k: state["config"][k] for k in ("rim_targets", "mirror", "mean_width")} == {
        "rim_targets": 2, "mirror": True, "mean_width": None}  # files state retired fields
    del state["config"]["rim_targets"]  # as the files written before the field existed
    del state["config"]["mirror"]
    with pytest.raises(ValueError, match=r"^path: a transition model file from before "
                       r"rim_targets, mirror existed, which this version no longer reads: "
                       r"train it again with dlo train transition$"):
        TransitionModel.from_state(state, device="cpu")
    both = old.state()
    both["config"].update(mirror=False, rim_targets=1)  # both handednesses, one target's rim
    with pytest.raises(ValueError, match=r"^path: a transition model file with rim_targets=1, "
                       r"mirror=False, which this version no longer supports"):
        TransitionModel.from_state(both, device="cpu")
    wide = old.state()
    wide["config"]["mean_width"] = 48  # a mean network wider than the ensemble
    with pytest.raises(ValueError, match=r"^path: a transition model file with mean_width=48, "
                       r"which this version no longer supports"):
        TransitionModel.from_state(wide, device="cpu")
    before = old.state()
    del before["config"]["mean_width"]  # written before the field existed: still read
    assert TransitionModel.from_state(before, device="cpu").config == old.config
    assert TransitionModel.from_state(old.state(), device="cpu").config == old.config


def test_chain_starts_only_link_consecutive_moves_of_one_cord():
    episode = np.array([0, 0, 0, 1, 1, 2])
    step = np.array([0, 1, 2, 0, 1, 0])
    assert chain_starts(episode, step, 1).tolist() == [0, 1, 2, 3, 4, 5]
    assert chain_starts(episode, step, 2).tolist() == [0, 1, 3]
    assert chain_starts(episode, step, 3).tolist() == [0]


@pytest.mark.slow
def test_training_learns_resumes_and_reports(data, tmp_path):
    tc = TransitionTrainConfig(steps=60, batch_size=64, eval_every=30, validation_fraction=0.2)
    model = train_transition_model(data, tmp_path, tc, TINY, device="cpu")
    curve = (tmp_path / CURVE_FILE).read_text().splitlines()
    assert curve[0].startswith("step,") and len(curve) == 3
    untrained = TransitionModel(TINY, device="cpu")
    idx = np.flatnonzero(data.grasp == 0)
    trained_err = error(model.predict(data.start[idx], "head", data.end_displacement(idx)),
                        data.next[idx]).mean()
    assert trained_err < error(untrained.predict(data.start[idx], "head",
                                                  data.end_displacement(idx)),
                               data.next[idx]).mean()
    with pytest.raises(ValueError, match="resume"):
        train_transition_model(data, tmp_path, tc, TINY, device="cpu")
    longer = TransitionTrainConfig(**{**tc.__dict__, "steps": 90})
    with pytest.raises(ValueError, match="other settings"):
        train_transition_model(data, tmp_path, longer, TINY, device="cpu", resume=True)
    again = train_transition_model(data, tmp_path, tc, TINY, device="cpu", resume=True)
    assert again.info["steps"] == 60  # the checkpoint was at the end: nothing more to do
    assert model.info["env_steps"] == data.env_steps() > len(data)  # the sample cost
    rows, rank = transition_report(model, data, max_moves=2)
    assert {r.group for r in rows} >= {"all", "head", "tail", "both", "0-5 cm"}
    assert -1.0 <= rank <= 1.0
    write_report(rows, rank, tmp_path)
    assert (tmp_path / "transition-metrics.png").stat().st_size > 1000
    assert (tmp_path / "transition-metrics.csv").read_text().startswith("moves,group,count")


def test_the_miss_weight_counts_each_error_beyond_the_margin_more_and_nothing_below_it():
    errors = torch.tensor([0.001, 0.004, 0.006, 0.02])
    plain = TransitionTrainConfig()
    assert float(one_move_loss(errors, plain)) == pytest.approx(float(errors.mean()))
    weighted = replace(plain, miss_weight=3.0, miss_margin=0.005)
    beyond = (0.001 + 0.015) / 4  # only the last two errors pass the margin
    assert float(one_move_loss(errors, weighted)) == pytest.approx(float(errors.mean())
                                                                   + 3.0 * beyond)
    below = errors[:2].clone().requires_grad_()
    one_move_loss(below, weighted).backward()
    assert torch.allclose(below.grad, torch.full((2,), 0.5))  # as without the weight
    with pytest.raises(ValueError, match="miss_weight"):
        TransitionTrainConfig(miss_weight=-1.0)


def test_training_can_start_from_a_saved_model(data, tmp_path):
    tc = TransitionTrainConfig(steps=30, batch_size=64, eval_every=30,
                               validation_fraction=0.2)
    first = train_transition_model(data, tmp_path / "a", tc, TINY, device="cpu")
    still = TransitionTrainConfig(**{**tc.__dict__, "steps": 1, "lr": 1e-12,
                                     "init": str(tmp_path / "a" / "transition.pt")})
    tuned = train_transition_model(data, tmp_path / "b", still, TINY, device="cpu")
    shapes = _shapes(3, seed=9)
    d = np.full((3, 2), 0.06, dtype=np.float32)
    assert np.allclose(tuned.predict(shapes, "head", d), first.predict(shapes, "head", d),
                       atol=1e-3)  # float16 weights on disk
    saved = TransitionModel.load(tmp_path / "a" / "transition.pt")
    assert tuned.info["init_model"] == {"fingerprint": fingerprint(saved.net),
                                        "info": saved.info}  # what it started from
    assert "init_model" not in first.info
    wider = TransitionModelConfig(**{**TINY.__dict__, "width": 16})
    with pytest.raises(ValueError, match="another architecture"):
        train_transition_model(data, tmp_path / "c", still, wider, device="cpu")


def test_contact_vectors_tell_a_point_at_the_wall_and_a_model_without_them_starts_one_with(
        data, tmp_path):
    from latent_model.move_frame import rim_vectors

    contact = replace(TINY, contact_reach=0.03)
    assert contact.rim_inputs == 2 * TINY.rim_inputs
    assert contact.inputs == TINY.inputs + 2 * TINY.rim_inputs
    recorder = _RimRecorder(contact, device="cpu").eval()
    shapes = _shapes(3, seed=12, margin=0.5)
    shapes[:, :, 0] += 0.985 - shapes[:, :, 0].max(axis=1, keepdims=True)  # 1.5 cm from it
    recorder.predict(shapes, "head", np.tile(np.float32([-0.05, 0.0]), (3, 1)))
    n, k = contact.n_points, contact.n_points + RIM_TARGETS
    assert recorder.rim.shape == (3, 2 * k, 2)
    # Moving left: in the frame the rim on the right (+x in the world) is at -x.
    near = rim_vectors(torch.from_numpy(shapes), 1.0, 0.03)  # the sharp vectors, world
    assert near[..., 0].max() == pytest.approx(0.5, abs=1e-5)
    assert torch.allclose(recorder.rim[:, k:k + n, 0], -near[..., 0], atol=1e-6)
    assert (recorder.rim[:, k:k + n].abs().sum(-1) > 0).sum() < (
        recorder.rim[:, :n].abs().sum(-1) > 0).sum()  # sharper: fewer points see it
    with pytest.raises(ValueError, match="contact_reach must be >= 0"):
        TransitionModelConfig(contact_reach=-0.01)
    old = TransitionModel(TINY, device="cpu").state()
    del old["config"]["contact_reach"]  # a file from before contact vectors: no longer read
    with pytest.raises(ValueError, match="a transition model file from before contact_reach "
                       "existed, which this version no longer reads"):
        TransitionModel.from_state(old)
    # Fine-tuning a model without contact vectors into one with them: same predictions first.
    tc = TransitionTrainConfig(steps=20, batch_size=64, eval_every=20,
                               validation_fraction=0.2)
    first = train_transition_model(data, tmp_path / "a", tc, TINY, device="cpu")
    still = TransitionTrainConfig(**{**tc.__dict__, "steps": 1, "lr": 1e-12,
                                     "init": str(tmp_path / "a" / "transition.pt")})
    grown = train_transition_model(data, tmp_path / "b", still, replace(TINY, contact_reach=0.03),
                                   device="cpu")
    assert grown.net.weights[0].shape[1] == contact.inputs
    at_wall = shapes + np.float32(0.01)  # nearer the wall: the contact vectors are not 0
    d = np.random.default_rng(12).uniform(-0.2, 0.2, size=(3, 4)).astype(np.float32)
    for end, move in (("head", d[:, :2]), ("both", d)):
        assert np.allclose(grown.predict(at_wall, end, move), first.predict(at_wall, end, move),
                           atol=1e-3)  # float16 weights on disk
    with pytest.raises(ValueError, match=r"another architecture or cord: contact_reach=0.03 "
                       r"\(this run 0.0\)$"):  # not the other way round
        train_transition_model(data, tmp_path / "c", TransitionTrainConfig(
            **{**still.__dict__, "init": str(tmp_path / "b" / "transition.pt")}), TINY,
            device="cpu")
    with pytest.raises(ValueError, match="contact_reach must be finite"):
        TransitionModelConfig(contact_reach=float("inf"))
    # The new inputs' weights are zero: whatever they hold, the network computes the same.
    net = first.net
    grown_net = net.with_inputs(TINY.contact_at, 7)
    x = torch.randn(4, TINY.inputs)
    wider_x = torch.cat([x[:, :TINY.contact_at], torch.randn(4, 7), x[:, TINY.contact_at:]], 1)
    assert torch.allclose(grown_net(wider_x), net(x), atol=1e-6)
    with pytest.raises(ValueError, match="at must be in 0"):
        net.with_inputs(TINY.inputs + 1, 2)


def test_distilling_keeps_the_ensemble_and_predicts_with_the_mean_network(data, tmp_path):
    tc = TransitionTrainConfig(steps=40, batch_size=64, eval_every=20,
                               validation_fraction=0.2)
    train_transition_model(data, tmp_path / "teacher", tc, TINY, device="cpu")
    teacher = TransitionModel.load(tmp_path / "teacher", device="cpu")  # as on disk: float16
    distil = TransitionTrainConfig(**{**tc.__dict__, "lr": 3e-3, "teacher_weight": 20,
                                      "teacher": str(tmp_path / "teacher" / "transition.pt")})
    student = train_transition_model(data, tmp_path / "student", distil, device="cpu")
    assert student.config.mean_network and student.mean_net.members == 1
    assert student.config.width == TINY.width  # the teacher's architecture, not the default's
    for mine, theirs in zip(student.net.state_dict().values(),
                            teacher.net.state_dict().values()):
        assert torch.equal(mine, theirs)  # the ensemble is the teacher's, unchanged
    idx = np.flatnonzero(data.grasp == 0)
    shapes, d = data.start[idx], data.end_displacement(idx)
    ensemble = teacher.predict(shapes, "head", d)
    assert np.array_equal(student.predict(shapes, "head", d, members=TINY.members), ensemble)
    pred, spread = student.predict(shapes, "head", d, return_std=True)
    assert np.array_equal(pred, student.predict(shapes, "head", d))  # one prediction
    assert not np.allclose(pred, ensemble, atol=1e-4)  # ... and it is the mean network's
    assert np.array_equal(spread, teacher.predict(shapes, "head", d, return_std=True)[1])

    # The mean network learnt: closer to the ensemble's mean than the member it started from.
    first = student.predict(shapes, "head", d, members=1)
    assert error(pred, ensemble).mean() < error(first, ensemble).mean()
    # Equivariant like the ensemble (away from the rim), and saved with the model.
    away, move = _shapes(6, seed=11), np.full((6, 2), 0.05, dtype=np.float32)
    turned = student.predict(_turn(away, 0.7, np.array([0.05, -0.1])), "head",
                             _turn(move, 0.7, np.zeros(2)))
    assert np.abs(turned - _turn(student.predict(away, "head", move), 0.7,
                                 np.array([0.05, -0.1]))).max() < 1e-5
    loaded = TransitionModel.load(tmp_path / "student", device="cpu")
    assert loaded.config.mean_network
    for mine, saved in zip(student.mean_net.parameters(), loaded.mean_net.parameters()):
        assert torch.equal(mine.detach().half().float(), saved)  # float16 on disk

    # predict's result is an ordinary C-ordered array, as the caller's next call expects
    assert pred.flags["C_CONTIGUOUS"] and spread.flags["C_CONTIGUOUS"]
    with pytest.raises(ValueError, match="not both"):
        TransitionTrainConfig(init="a.pt", teacher="b.pt")
    with pytest.raises(ValueError, match="mean network is made by distilling"):
        train_transition_model(data, tmp_path / "x", tc,
                               TransitionModelConfig(**{**TINY.__dict__, "mean_network": True}),
                               device="cpu")
    # Fine-tuning a distilled model tunes its ensemble; the old mean network is not kept.
    still = TransitionTrainConfig(**{**tc.__dict__, "steps": 1, "lr": 1e-12,
                                     "init": str(tmp_path / "student" / "transition.pt")})
    tuned = train_transition_model(data, tmp_path / "tuned", still, TINY, device="cpu")
    assert not tuned.config.mean_network and tuned.mean_net is None
    assert np.allclose(tuned.predict(shapes, "head", d), ensemble, atol=1e-3)
    other = TransitionModel(TransitionModelConfig(n_points=12, width=8, depth=1, members=2),
                            device="cpu")
    other.save(tmp_path / "other.pt")
    wrong = TransitionTrainConfig(**{**distil.__dict__, "teacher": str(tmp_path / "other.pt")})
    with pytest.raises(ValueError, match="n_points"):
        train_transition_model(data, tmp_path / "wrong", wrong, device="cpu")


def test_a_mean_network_by_grasp_runs_one_network_per_move_and_learns_each_grasp_apart(
        data, tmp_path):
    tc = TransitionTrainConfig(steps=40, batch_size=64, eval_every=20,
                               validation_fraction=0.2)
    train_transition_model(data, tmp_path / "teacher", tc, TINY, device="cpu")
    distil = TransitionTrainConfig(**{**tc.__dict__, "lr": 3e-3,
                                      "teacher": str(tmp_path / "teacher" / "transition.pt")})
    split = TransitionModelConfig(**{**TINY.__dict__, "mean_network": True,
                                     "mean_by_grasp": True})
    student = train_transition_model(data, tmp_path / "student", distil, split, device="cpu")
    assert student.config.mean_by_grasp and student.mean_net.members == 1
    first, second = (w for w in student.mean_net.routes.weights[0])
    assert not torch.equal(first, second)  # both started from the same member, each learnt
    tensors = as_tensors(student, data)
    with torch.no_grad():  # a mixed batch: every row as if it came alone
        mixed = student(tensors.start, tensors.grasp, tensors.moves, net=student.mean_net)
        for code in range(3):
            idx = torch.nonzero(tensors.grasp == code).squeeze(1)
            alone = student(tensors.start[idx], tensors.grasp[idx], tensors.moves[idx],
                            net=student.mean_net)
            assert torch.allclose(mixed[:, idx], alone, atol=1e-6)
    idx = np.flatnonzero(data.grasp == 2)
    both = student.predict(data.start[idx], "both", data.end_displacement(idx))
    head = student.predict(data.start[:5], "head", np.full((5, 2), 0.05, dtype=np.float32))
    with torch.no_grad():  # the second network alone makes both-ends predictions
        student.mean_net.routes.weights[-1][1].mul_(2.0)
    assert not np.allclose(student.predict(data.start[idx], "both",
                                           data.end_displacement(idx)), both, atol=1e-4)
    assert np.array_equal(student.predict(data.start[:5], "head",
                                          np.full((5, 2), 0.05, dtype=np.float32)), head)
    loaded = TransitionModel.load(tmp_path / "student", device="cpu")
    assert loaded.config.mean_by_grasp
    assert np.allclose(loaded.predict(data.start[idx], "both", data.end_displacement(idx)),
                       both, atol=1e-3)  # float16 on disk
    with pytest.raises(ValueError, match="mean_by_grasp needs mean_network"):
        TransitionModelConfig(mean_by_grasp=True)


def test_the_mean_network_starts_as_the_ensembles_first_member_and_then_learns(data, tmp_path):
    tc = TransitionTrainConfig(steps=20, batch_size=64, eval_every=20,
                               validation_fraction=0.2)
    teacher = train_transition_model(data, tmp_path / "teacher", tc, TINY, device="cpu")
    shapes = _shapes(8, seed=31)
    move = np.random.default_rng(31).uniform(-0.2, 0.2, size=(8, 4))
    distil = TransitionTrainConfig(**{**tc.__dict__, "steps": 1, "lr": 1e-12,  # no change
                                      "teacher": str(tmp_path / "teacher" / "transition.pt")})
    for by_grasp in (True, False):
        mc = replace(TINY, mean_network=True, mean_by_grasp=by_grasp)
        start = train_transition_model(data, tmp_path / f"start{by_grasp}", distil, mc,
                                       device="cpu")
        assert start.net.weights[0].shape[-1] == TINY.width
        for end, d in (("head", move[:, :2]), ("both", move)):
            assert np.allclose(start.predict(shapes, end, d),
                               start.predict(shapes, end, d, members=1), atol=1e-6)
    trained = train_transition_model(data, tmp_path / "tuned", TransitionTrainConfig(
        **{**distil.__dict__, "steps": 20, "lr": 3e-3}), mc, device="cpu")
    loaded = TransitionModel.load(tmp_path / "tuned", device="cpu")
    assert loaded.mean_net.members == 1
    assert np.allclose(loaded.predict(shapes, "both", move),
                       trained.predict(shapes, "both", move), atol=1e-3)  # float16 on disk
    assert not np.allclose(trained.predict(shapes, "both", move),
                           teacher.predict(shapes, "both", move, members=1), atol=1e-4)


def test_paired_moves_give_each_start_reachable_moves_of_its_grasp_from_other_transitions(
        data, model):
    paired = paired_moves(model, data, copies=2, seed=0)
    assert len(paired.grasp) == 2 * len(data)
    names = ("head", "tail", "both")
    for code, name in enumerate(names):
        mine = paired.grasp.numpy() == code
        idx = np.flatnonzero(data.grasp == code)
        assert mine.sum() == 2 * len(idx)  # every start twice, with its own grasp
        starts, moves = paired.start.numpy()[mine], paired.moves.numpy()[mine]
        assert np.array_equal(starts, np.concatenate([data.start[idx]] * 2))
        commanded = data.end_displacement(idx)
        held = {"head": [0], "tail": [1], "both": [0, 1]}[name]
        assert not moves[:, [k for k in (0, 1) if k not in held]].any()  # a free end stays
        made = moves[:, held].reshape(len(moves), -1)
        # Already reachable: carrying a paired move out again changes nothing.
        assert np.allclose(model.reachable_moves(starts, name, made), moves, atol=1e-6)
        # Another transition's command carried out from this start (clipped as it goes).
        k = len(commanded)
        options = model.reachable_moves(np.repeat(starts, k, axis=0), name,
                                        np.tile(commanded, (len(starts), 1)))
        options = options.reshape(len(starts), k, 2, 2)
        assert np.isclose(options, moves[:, None], atol=1e-6).all(axis=(2, 3)).any(axis=1).all()
        own = np.isclose(options[np.arange(len(starts)), np.tile(np.arange(k), 2)], moves,
                         atol=1e-6).all(axis=(1, 2))
        assert own.mean() < 0.5  # mostly not the start's own move
    assert len(paired_moves(model, data, copies=1, seed=0).grasp) == len(data)


def test_distilling_with_the_teachers_moves_learns_the_ensemble_on_moves_off_the_data(
        data, tmp_path):
    tc = TransitionTrainConfig(steps=40, batch_size=64, eval_every=20,
                               validation_fraction=0.2)
    train_transition_model(data, tmp_path / "teacher", tc, TINY, device="cpu")
    teacher = TransitionModel.load(tmp_path / "teacher", device="cpu")
    distil = TransitionTrainConfig(**{**tc.__dict__, "lr": 3e-3, "teacher_weight": 20,
                                      "teacher_moves": 3,
                                      "teacher": str(tmp_path / "teacher" / "transition.pt")})
    student = train_transition_model(data, tmp_path / "student", distil, device="cpu")
    assert student.info["train_config"]["teacher_moves"] == 3
    paired = paired_moves(teacher, data, copies=1, seed=5)  # moves the data never made
    both = paired.grasp.numpy() == 2
    starts, moves = paired.start.numpy()[both], paired.moves.numpy()[both].reshape(-1, 4)
    ensemble = teacher.predict(starts, "both", moves)
    first = student.predict(starts, "both", moves, members=1)
    assert error(student.predict(starts, "both", moves), ensemble).mean() < \
        error(first, ensemble).mean()
    with pytest.raises(ValueError, match="need one"):
        TransitionTrainConfig(teacher_moves=1)
    with pytest.raises(ValueError, match="teacher_moves must be an int >= 0"):
        TransitionTrainConfig(teacher="t.pt", teacher_moves=-1)


class _Stop(Exception):
    pass


def test_an_interrupted_distillation_resumes_from_its_checkpoint_and_only_with_its_teacher(
        data, tmp_path):
    tc = TransitionTrainConfig(steps=20, batch_size=32, eval_every=20,
                               validation_fraction=0.2)
    train_transition_model(data, tmp_path / "teacher", tc, TINY, device="cpu")
    teacher = str(tmp_path / "teacher" / "transition.pt")
    distil = TransitionTrainConfig(**{**tc.__dict__, "steps": 40, "eval_every": 10,
                                      "teacher": teacher})

    def stop_at_25(step, stats):
        if step == 25:
            raise _Stop

    with pytest.raises(_Stop):
        train_transition_model(data, tmp_path / "student", distil, device="cpu",
                               progress=stop_at_25)
    assert len((tmp_path / "student" / CURVE_FILE).read_text().splitlines()) == 3  # 10, 20
    steps = []
    done = train_transition_model(data, tmp_path / "student", distil, device="cpu",
                                  resume=True, progress=lambda step, stats: steps.append(step))
    assert steps[0] == 21 and steps[-1] == 40 and done.info["steps"] == 40
    assert done.info["teacher_ensemble"] and done.config.mean_network

    # A teacher file that now holds another ensemble is refused, not silently mixed in.
    torch.manual_seed(5)
    TransitionModel(TINY, device="cpu").save(teacher)
    longer = TransitionTrainConfig(**{**distil.__dict__, "steps": 40})
    with pytest.raises(ValueError, match="distils another ensemble"):
        train_transition_model(data, tmp_path / "student", longer, device="cpu", resume=True)


def test_a_fine_tuning_resumes_only_from_the_model_it_started_from(data, tmp_path):
    tc = TransitionTrainConfig(steps=10, batch_size=32, eval_every=10,
                               validation_fraction=0.2)
    train_transition_model(data, tmp_path / "first", tc, TINY, device="cpu")
    init = str(tmp_path / "first" / "transition.pt")
    tune = TransitionTrainConfig(**{**tc.__dict__, "steps": 20, "init": init})

    def stop_at_15(step, stats):
        if step == 15:
            raise _Stop

    with pytest.raises(_Stop):
        train_transition_model(data, tmp_path / "tuned", tune, TINY, device="cpu",
                               progress=stop_at_15)
    torch.manual_seed(7)
    TransitionModel(TINY, device="cpu").save(init)  # another model where init was
    with pytest.raises(ValueError, match="fine-tunes another model than init"):
        train_transition_model(data, tmp_path / "tuned", tune, TINY, device="cpu", resume=True)


def test_a_checkpoint_from_before_distillation_existed_is_refused_on_resume(data, tmp_path):
    tc = TransitionTrainConfig(steps=20, batch_size=32, eval_every=10,
                               validation_fraction=0.2)

    def stop_at_15(step, stats):
        if step == 15:
            raise _Stop

    with pytest.raises(_Stop):
        train_transition_model(data, tmp_path, tc, TINY, device="cpu", progress=stop_at_15)
    path = tmp_path / "transition-checkpoint.pt"
    saved = torch.load(path, weights_only=True)
    del saved["model_config"]["mean_network"]  # as the files written before the field
    torch.save(saved, path)
    with pytest.raises(ValueError, match="a training checkpoint from before mean_network "
                       "existed, which this version no longer reads: give another --out"):
        train_transition_model(data, tmp_path, tc, TINY, device="cpu", resume=True)


def test_mean_interval_covers_the_true_mean_and_narrows_with_more_moves():
    from latent_model.transition_metrics import ErrorRow, mean_interval

    rng = np.random.default_rng(3)
    covered = []
    for _ in range(60):  # heavy-tailed errors of true mean exp(0.5)
        low, high = mean_interval(rng.lognormal(0.0, 1.0, 300))
        covered.append(low <= np.exp(0.5) <= high)
    assert 0.83 <= np.mean(covered) <= 1.0  # a 95 % interval; 60 trials
    few, many = rng.lognormal(0.0, 1.0, 100), rng.lognormal(0.0, 1.0, 10_000)
    assert np.ptp(mean_interval(many)) < 0.2 * np.ptp(mean_interval(few))
    assert mean_interval(few) == mean_interval(few)  # reproducible
    row = ErrorRow.of(1, "head", few / 100)
    assert row.mean_low_cm < row.mean_cm < row.mean_high_cm
    assert 0.0 < row.within_low < row.within_1cm < row.within_high < 1.0  # some within 1 cm
    assert (row.within_low, row.within_high) == mean_interval(few / 100 <= 0.01)
    assert np.isnan(mean_interval(np.ones(1))).all()
    # Moves of one episode are correlated: resampling whole episodes widens the interval.
    twice = np.repeat(few, 4)
    alone, grouped = mean_interval(twice), mean_interval(twice, np.repeat(np.arange(100), 4))
    assert np.ptp(grouped) > 1.5 * np.ptp(alone)
    with pytest.raises(ValueError, match="level must be in"):
        mean_interval(few, level=95)


def test_a_model_of_one_network_reports_without_a_spread(data):
    from latent_model.transition_metrics import spread_rank_correlation

    one = TransitionModel(replace(TINY, members=1), device="cpu").eval()
    assert np.isnan(spread_rank_correlation(one, data))
    rows, rank = transition_report(one, data, max_moves=1)
    assert np.isnan(rank) and rows[0].count == len(data)


def test_a_model_of_one_cord_starts_a_model_of_several_cords(data, tmp_path):
    """--init of a one-cord model with --cord-inputs: the cord's inputs start at zero weight,
    so the grown model first predicts every cord as the one-cord model predicts its own."""
    from dlo_env import CordParams

    tc = TransitionTrainConfig(steps=20, batch_size=64, eval_every=20,
                               validation_fraction=0.2)
    first = train_transition_model(data, tmp_path / "a", tc, replace(TINY, contact_reach=0.03),
                                   device="cpu")
    still = TransitionTrainConfig(**{**tc.__dict__, "steps": 1, "lr": 1e-12,
                                     "init": str(tmp_path / "a" / "transition.pt")})
    grown = train_transition_model(data, tmp_path / "b", still,
                                   replace(TINY, contact_reach=0.03, cord_inputs=True),
                                   device="cpu")
    assert grown.config.cord_inputs
    shapes = data.start[:5]
    d = np.random.default_rng(3).uniform(-0.2, 0.2, size=(5, 4)).astype(np.float32)
    other = CordParams(bending_stiffness=0.004, mass=0.25)
    for end, move in (("head", d[:, :2]), ("both", d)):
        base = first.predict(shapes, end, move, inextensible=False)
        assert np.allclose(grown.predict(shapes, end, move, inextensible=False), base, atol=1e-3)
        assert np.allclose(grown.predict(shapes, end, move, params=other, inextensible=False),
                           base, atol=1e-3)
    with pytest.raises(ValueError, match=r"another architecture or cord: cord_inputs=True "
                       r"\(this run False\)$"):  # not the other way round
        train_transition_model(data, tmp_path / "c", TransitionTrainConfig(
            **{**still.__dict__, "init": str(tmp_path / "b" / "transition.pt")}),
            replace(TINY, contact_reach=0.03), device="cpu")


@pytest.mark.parametrize(("grasp", "move"), [("head", [-0.4, 0.0]), ("tail", [-0.2, 0.6]),
                                             ("both", [-0.4, 0.0, 0.0, 0.6])])
def test_with_pegs_the_model_moves_the_grippers_as_the_simulator_does(grasp, move):
    from dlo_env.cord import Cord
    from dlo_env.tasks import apply_action, split_move

    model = TransitionModel(replace(TINY, members=2), device="cpu")
    shape = np.stack([np.linspace(-0.5, 0.5, 20), np.zeros(20)], 1).astype(np.float32)
    pegs = np.array([[-0.7, 0.02], [0.42, 0.3], [0.35, 0.26]])
    d = np.array(move)
    cord = Cord(grasp=grasp, pegs=pegs)
    cord.reset(shape)
    before = cord.gripper_positions()
    for action in split_move(d, model.config.max_step):
        apply_action(cord, action, model.config.max_step)
    real = np.zeros((2, 2))
    for row, end in enumerate(("head", "tail")):
        if end in before:
            real[row] = cord.gripper_positions()[end] - before[end]
    moves = model.reachable_moves(shape[None], grasp, d[None], pegs=pegs)[0]
    np.testing.assert_allclose(moves, real, atol=1e-6)
    free = model.reachable_moves(shape[None], grasp, d[None])[0]
    assert np.abs(free - moves).max() > 0.05  # the pegs stopped a gripper
    if grasp != "both":  # (this straight cord is wider than both ends may be held apart)
        # predict applies the same rule (the networks themselves do not see the pegs).
        stopped = model.predict(shape, grasp, d, pegs=pegs, inextensible=False)
        own = moves[0] if grasp == "head" else moves[1]
        np.testing.assert_allclose(stopped, model.predict(shape, grasp, own, inextensible=False),
                                   atol=1e-5)


def test_a_model_that_sees_pegs_is_equivariant_and_sees_nothing_far_from_them():
    config = replace(TINY, members=2, peg_reach=0.1)
    model = TransitionModel(config, device="cpu")
    rng = np.random.default_rng(0)
    shape = np.stack([np.linspace(-0.4, 0.4, 20), 0.05 * np.sin(np.linspace(0, 3, 20))], 1)
    shape = shape.astype(np.float32)
    pegs = np.array([[0.0, 0.08], [0.3, -0.06]], dtype=np.float32)
    move = np.array([0.05, 0.1], dtype=np.float32)
    near = model.predict(shape, "head", move, pegs=pegs, inextensible=False)
    # Pegs change what it predicts; pegs far from the cord and the target change nothing.
    assert np.abs(near - model.predict(shape, "head", move, inextensible=False)).max() > 1e-6
    far = np.array([[0.8, 0.8]], dtype=np.float32)
    np.testing.assert_allclose(model.predict(shape, "head", move, pegs=far, inextensible=False),
                               model.predict(shape, "head", move, inextensible=False), atol=1e-6)
    # Turning and shifting the world, pegs included, turns and shifts the prediction.
    angle = rng.uniform(-np.pi, np.pi)
    rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    shift = np.array([0.05, -0.03])

    def moved(x):
        return (x @ rot.T + shift).astype(np.float32)

    turned = model.predict(moved(shape), "head", (move @ rot.T).astype(np.float32),
                           pegs=moved(pegs), inextensible=False)
    np.testing.assert_allclose(turned, moved(near), atol=2e-5)


def test_peg_inputs_added_at_zero_weight_predict_as_the_model_without_them():
    plain = TransitionModel(replace(TINY, members=2), device="cpu")
    config = replace(plain.config, peg_reach=0.1)
    seeing = TransitionModel(config, device="cpu")
    seeing.net.load_state_dict(plain.net.with_inputs(plain.config.peg_at,
                                                     2 * config.peg_inputs).state_dict())
    shape = np.stack([np.linspace(-0.4, 0.4, 20), np.zeros(20)], 1).astype(np.float32)
    pegs = np.array([[0.0, 0.05], [-0.2, -0.05]], dtype=np.float32)
    move = np.array([0.1, 0.1], dtype=np.float32)
    np.testing.assert_allclose(seeing.predict(shape, "head", move, pegs=pegs),
                               plain.predict(shape, "head", move, pegs=pegs), atol=1e-6)


def test_a_model_that_sees_pegs_trains_on_data_around_pegs(tmp_path):
    from dlo_env.dataset.transitions import TransitionCollectConfig, collect_transition_chunk
    from latent_model.transition_training import TransitionTrainConfig, train_transition_model

    data = collect_transition_chunk(TransitionCollectConfig(seed=5, max_pegs=2), 0, 40)
    assert data.peg_count.any()
    model = train_transition_model(
        data, tmp_path / "m", TransitionTrainConfig(steps=4, batch_size=16, eval_every=2),
        replace(TINY, members=2, peg_reach=0.1))
    assert model.config.peg_reach == 0.1
    loaded = TransitionModel.load(tmp_path / "m")
    i = int(np.flatnonzero(data.peg_count)[0])
    name = ("head", "tail", "both")[int(data.grasp[i])]
    args = (data.start[i], name, data.end_displacement(np.array([i]))[0])
    np.testing.assert_allclose(loaded.predict(*args, pegs=data.peg_list(i)),
                               model.predict(*args, pegs=data.peg_list(i)), atol=1e-3)
    # Its mean network is distilled on the same data (the teacher sees the pegs).
    student = train_transition_model(
        data, tmp_path / "mean", TransitionTrainConfig(
            steps=2, batch_size=16, eval_every=2, teacher=str(tmp_path / "m" / "transition.pt")))
    assert student.config.peg_reach == 0.1 and student.mean_net is not None


def test_a_gripper_sliding_along_the_edge_stops_at_a_peg_there_as_in_the_simulator():
    from dlo_env.cord import Cord
    from dlo_env.tasks import apply_action, split_move

    model = TransitionModel(replace(TINY, members=2), device="cpu")
    # The head at x = 0.9, 10 cm from the right edge.
    shape = np.stack([np.linspace(0.9, -0.1, 20), np.zeros(20)], 1).astype(np.float32)
    pegs = np.array([[0.97, 0.5]])
    d = np.array([0.5, 1.0])  # clipped at the edge, then sliding up into the peg
    cord = Cord(pegs=pegs)
    cord.reset(shape)
    before = cord.gripper_positions()["head"]
    for action in split_move(d, model.config.max_step):
        apply_action(cord, action, model.config.max_step)
    real = cord.gripper_positions()["head"] - before
    moves = model.reachable_moves(shape[None], "head", d[None], pegs=pegs)[0]
    np.testing.assert_allclose(moves[0], real, atol=1e-6)
    assert real[1] < 0.6  # the peg stopped it


def test_a_model_of_one_cord_records_the_cord_it_trained_on_and_its_file_keeps_it(tmp_path):
    slippery = CordParams(friction=0.3, mass=0.2, bending_stiffness=0.02)
    data = collect_transition_chunk(TransitionCollectConfig(seed=3, cord=slippery), 0, 20)
    tc = TransitionTrainConfig(steps=2, batch_size=16, eval_every=2, validation_fraction=0.2)
    model = train_transition_model(data, tmp_path, tc, TINY, device="cpu")
    assert model.cord_params == slippery
    assert TransitionModel.load(tmp_path, device="cpu").cord_params == slippery
    with pytest.raises(ValueError, match="trained for one cord"):
        model.predict(_shapes(1)[0], "head", [0.05, 0.0], params=CordParams())


def test_a_file_without_the_cords_record_is_of_its_training_datas_cord_else_the_default():
    state = TransitionModel(TINY, device="cpu").state()
    assert not {"cord_mass", "cord_friction", "cord_bending_stiffness"} & set(state["config"])
    assert TransitionModel.from_state(state, device="cpu").cord_params == CordParams()
    state["info"] = {"data": {"cord": {**asdict(CordParams()), "friction": 0.3}}}
    assert TransitionModel.from_state(state, device="cpu").cord_params == CordParams(
        friction=0.3)
