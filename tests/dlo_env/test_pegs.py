"""Pegs on the table: static circles the cord goes around, in the cord and both environments."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import dlo_env  # noqa: F401  (registers the environments)
from dlo_env.cord import (
    LINK_RADIUS,
    PEG_GUARD,
    PEG_RADIUS,
    Cord,
    peg_clearance,
    peg_contact,
    reachable_targets,
)
from dlo_env.shapes import TABLE_HALF
from dlo_env.tasks import (
    PEG_CLEARANCE,
    load_tasks,
    make_task,
    save_tasks,
)

ENVS = ("dlo_env/DLOEndpoint-v0", "dlo_env/DLODualEndpoint-v0")
STRAIGHT = np.stack([np.linspace(-0.5, 0.5, 20), np.zeros(20)], 1).astype(np.float32)


def _inside(shape: np.ndarray, pegs: np.ndarray, radius: float) -> float:
    """How deep the deepest point lies inside a peg (<= 0: none inside)."""
    if len(pegs) == 0:
        return -np.inf
    dist = np.linalg.norm(np.asarray(shape, np.float64)[:, None] - pegs[None], axis=-1)
    return float((radius - dist).max())


def test_peg_contact_is_the_first_touch_along_the_move():
    pegs = np.array([[1.0, 0.0], [0.5, 5.0]])
    # From the origin along +x by 2: touches the first peg (reach 0.5) at x = 0.5, a quarter.
    assert peg_contact(np.zeros((1, 2)), np.array([[2.0, 0.0]]), pegs, 0.5) == pytest.approx(0.25)
    # Away from every peg, or stopping short: the whole move.
    assert peg_contact(np.zeros((1, 2)), np.array([[-2.0, 0.0]]), pegs, 0.5) == 1.0
    assert peg_contact(np.zeros((1, 2)), np.array([[0.4, 0.0]]), pegs, 0.5) == 1.0
    # Touching already: pressing in gives nothing, leaving is free.
    at = np.array([[0.5, 0.0]])
    assert peg_contact(at, np.array([[0.1, 0.0]]), pegs, 0.5) == 0.0
    assert peg_contact(at, np.array([[-0.1, 0.0]]), pegs, 0.5) == 1.0
    # Two ends: both stop at the share of the first touch; batched over leading axes.
    starts = np.array([[[0.0, 0.0], [0.0, 1.0]]] * 3)
    moves = np.array([[[2.0, 0.0], [0.0, 0.0]], [[0.0, 0.0], [0.0, 0.0]],
                      [[0.0, 0.0], [0.5, 4.0]]])
    expected = [0.25, 1.0, 1.0 - 0.5 / np.hypot(0.5, 4.0)]
    assert peg_contact(starts, moves, pegs, 0.5) == pytest.approx(expected)


def test_a_gripper_stops_where_it_would_touch_a_peg():
    cord = Cord(pegs=[[-0.7, 0.0]])
    cord.reset(STRAIGHT)
    cord.move(head=(-0.5, 0.0))  # straight into the peg
    stop = -0.7 + PEG_RADIUS + LINK_RADIUS + PEG_GUARD
    np.testing.assert_allclose(cord.gripper_positions()["head"], [stop, 0.0], atol=1e-9)
    cord.move(head=(-0.1, 0.0))  # pressing on: no motion
    np.testing.assert_allclose(cord.gripper_positions()["head"], [stop, 0.0], atol=1e-9)
    cord.move(head=(0.0, 0.2))  # sideways: free
    np.testing.assert_allclose(cord.gripper_positions()["head"], [stop, 0.2], atol=1e-9)
    # The batched rule a learned model uses is the simulator's.
    targets = reachable_targets(np.array([[[-1.2, 0.0]]]), starts=np.array([[[-0.5, 0.0]]]),
                                pegs=cord.pegs)
    np.testing.assert_allclose(targets[0, 0], [stop, 0.0], atol=1e-9)
    with pytest.raises(ValueError, match="starts must be given with pegs"):
        reachable_targets(np.zeros((1, 2)), pegs=cord.pegs)


def test_pegs_change_in_a_running_simulation_and_bad_pegs_are_refused():
    cord = Cord()
    cord.reset(STRAIGHT)
    cord.set_pegs([[0.0, 0.1]])
    cord.move(head=(0.0, 0.3))  # the head sweeps the cord up into the peg
    cord.move(head=(0.9, 0.0))
    assert _inside(cord.shape, cord.pegs, PEG_RADIUS) <= 0
    cord.set_pegs(None)
    assert cord.pegs.shape == (0, 2)
    with pytest.raises(ValueError, match=r"pegs must be an array of peg centres, shape \(k, 2\)"):
        Cord(pegs=[1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match=r"pegs must be finite, got \[nan, 0.0\]"):
        Cord(pegs=[[0.1, 0.1], [np.nan, 0.0]])
    with pytest.raises(ValueError, match="pegs must lie on the table"):
        Cord(pegs=[[0.0, TABLE_HALF + 0.1]])
    with pytest.raises(ValueError, match="peg_radius must be a number"):
        Cord(peg_radius=0.0)


@pytest.mark.parametrize("env_id", ENVS)
def test_no_point_inside_a_peg_or_off_the_table_under_random_full_speed_actions(env_id):
    env = gym.make(env_id, max_pegs=4, judge_at_rest=False)
    rng = np.random.default_rng(0)
    base = env.unwrapped
    pegged, worst = 0, -np.inf
    for episode in range(50):
        _, info = env.reset(seed=episode)
        pegs = np.asarray(info["pegs"], dtype=np.float64).reshape(-1, 2)
        pegged += len(pegs) > 0
        for _ in range(100):  # 5 000 actions per environment
            action = rng.choice([-1.0, 1.0], size=env.action_space.shape)
            if rng.uniform() < 0.3:
                action = rng.uniform(-1.0, 1.0, size=env.action_space.shape)
            obs, *_ = env.step(action.astype(np.float32))
            shape = obs["achieved_goal"].reshape(-1, 2)
            assert (np.abs(shape) <= TABLE_HALF).all()
            worst = max(worst, _inside(shape, pegs, base.peg_radius))
    assert pegged >= 35  # most episodes have pegs (0 to 4 each)
    assert worst <= 0.0, f"a point lay {worst * 1000:.2f} mm inside a peg"


@pytest.mark.parametrize("env_id", ENVS)
def test_the_observation_holds_the_pegs_at_a_fixed_size_with_a_mask(env_id):
    plain = gym.make(env_id)
    env = gym.make(env_id, max_pegs=3)
    size = plain.observation_space["observation"].shape[0]
    assert env.observation_space["observation"].shape == (size + 9,)
    pegs = np.array([[0.0, 0.6], [-0.6, 0.6]], dtype=np.float32)
    obs, info = env.reset(options={"pegs": pegs})
    assert env.observation_space.contains(obs)
    extra = obs["observation"][size:]
    np.testing.assert_array_equal(extra[:4], pegs.reshape(-1))
    np.testing.assert_array_equal(extra[4:6], 0.0)
    np.testing.assert_array_equal(extra[6:], [1.0, 1.0, 0.0])
    np.testing.assert_array_equal(np.asarray(info["pegs"]), pegs)
    np.testing.assert_array_equal(env.unwrapped.pegs, pegs)
    assert peg_clearance(obs["achieved_goal"].reshape(-1, 2), pegs) >= PEG_CLEARANCE - 1e-6
    # The empty table keeps today's observation.
    assert plain.reset(seed=0)[0]["observation"].shape == (size,)
    obs, info = env.reset(options={"pegs": np.zeros((0, 2))})
    assert info["pegs"] == () and not obs["observation"][size:].any()


@pytest.mark.parametrize("env_id", ENVS)
def test_a_task_with_pegs_replays_to_its_goal_bitwise(env_id):
    env = gym.make(env_id, max_pegs=3, judge_at_rest=False)
    for seed in range(4):
        _, info = env.reset(seed=seed)
        task = info["task"]
        if len(task.pegs) == 0:
            continue
        obs, _ = env.reset(options={"task": task})
        for action in task.reference_actions:
            obs, *_ = env.step(action)
        np.testing.assert_array_equal(obs["achieved_goal"], task.goal.reshape(-1))
        again = make_task(task.seed, task.difficulty, task.grasp, pegs=len(task.pegs))
        np.testing.assert_array_equal(again.goal, task.goal)
        np.testing.assert_array_equal(again.pegs, task.pegs)
        return
    pytest.fail("no task with pegs in four resets")


def test_wrong_peg_options_get_one_line_errors():
    env = gym.make("dlo_env/DLOEndpoint-v0", max_pegs=2)
    with pytest.raises(ValueError, match="max_pegs must be an int from 0 to"):
        gym.make("dlo_env/DLOEndpoint-v0", max_pegs=-1)
    with pytest.raises(ValueError, match=r"holds 3 pegs, more than this environment observes"):
        env.reset(options={"pegs": np.zeros((3, 2)) + [[0.1, 0.1]]})
    with pytest.raises(ValueError, match=r"options\['start'\] crosses a peg"):
        env.reset(options={"start": STRAIGHT, "pegs": [[0.0, 0.0]]})
    with pytest.raises(ValueError, match=r"options\['goal'\] crosses a peg"):
        env.reset(options={"goal": STRAIGHT, "pegs": [[0.2, 0.0]]})
    env.reset(seed=1)
    with pytest.raises(ValueError, match="carries its pegs"):
        env.reset(options={"task": env.unwrapped.task, "pegs": [[0.0, 0.9]]})
    task = make_task(3, 1, pegs=3)
    with pytest.raises(ValueError, match="has 3 pegs, more than this environment observes"):
        env.reset(options={"task": task})
    with pytest.raises(ValueError, match="start: the cord crosses a peg"):
        make_task(0, 1, start=STRAIGHT, pegs=[[0.0, 0.0]])
    with pytest.raises(ValueError, match="could not place 200 pegs near the cord"):
        make_task(0, 1, pegs=200)
    with pytest.raises(ValueError, match=r"less the radius 0.02 m"):
        Cord(pegs=[[0.0, TABLE_HALF - 0.01]])


def test_a_goal_resting_against_a_peg_is_taken_with_its_pegs():
    from dlo_env.peg_suites import load_route_suite

    env = gym.make("dlo_env/DLOEndpoint-v0", max_pegs=4, judge_at_rest=False)
    for task in load_route_suite("route-2", limit=3):  # goals that rest against a peg
        obs, info = env.reset(options={"start": task.start, "goal": task.goal,
                                       "pegs": task.pegs})
        np.testing.assert_array_equal(obs["desired_goal"], task.goal.reshape(-1))
        info["pegs"][0][0] = 9.0  # the info holds copies
        assert task.pegs[0, 0] != 9.0


def test_a_goal_given_with_pegs_gets_a_start_clear_of_them():
    env = gym.make("dlo_env/DLOEndpoint-v0", max_pegs=1)
    pegs = np.array([[0.0, 0.4]], dtype=np.float32)
    _, info = env.reset(seed=3, options={"goal": STRAIGHT, "pegs": pegs})
    assert peg_clearance(env.unwrapped.cord.shape, pegs) >= PEG_CLEARANCE - 1e-6
    assert info["task"] is None


def test_task_files_keep_the_pegs_and_read_files_without_them(tmp_path):
    tasks = [make_task(5, 2, pegs=2), make_task(6, 1), make_task(7, 1, pegs=1, peg_radius=0.03)]
    save_tasks(tmp_path / "t.npz", tasks)
    back = load_tasks(tmp_path / "t.npz")
    for a, b in zip(tasks, back):
        np.testing.assert_array_equal(a.pegs, b.pegs)
        assert a.peg_radius == b.peg_radius
    # A version-1 file (before pegs): no pegs.
    with np.load(tmp_path / "t.npz") as data:
        arrays = {k: data[k] for k in data.files if not k.startswith("peg")}
    arrays["format_version"] = np.array(1)
    np.savez(tmp_path / "old.npz", **arrays)
    assert all(t.pegs.shape == (0, 2) for t in load_tasks(tmp_path / "old.npz"))


def test_a_vector_env_with_pegs_steps():
    envs = gym.make_vec("dlo_env/DLOEndpoint-v0", num_envs=2, vectorization_mode="sync",
                        max_pegs=2)
    obs, info = envs.reset(seed=0)
    assert obs["observation"].shape == (2, 42 + 6)
    obs, *_ = envs.step(np.zeros((2, 2), dtype=np.float32))
    envs.close()


def test_pegs_with_friction_hold_a_wrapped_cord_by_the_capstan_effect():
    from dataclasses import replace

    from scripts import load_script

    capstan = load_script("benchmarks/peg_capstan.py")
    force = {}
    for mu in (0.0, 0.3):
        params = replace(capstan.CordParams(), friction=0.0, peg_friction=mu)
        angle, low = capstan.slide_force(params, 2, 1.0, towards=True)
        _, high = capstan.slide_force(params, 2, 1.0, towards=False)
        force[mu] = (low, high)
    assert 1.5 < angle < 1.7  # a quarter turn: two links round the 2 cm peg
    assert abs(force[0.0][0] - 1.0) < 0.05 and abs(force[0.0][1] - 1.0) < 0.05  # no friction
    low, high = force[0.3]  # the capstan equation: exp(-0.3 angle) = 0.62, exp(0.3 angle) = 1.62
    assert 0.55 < low < 0.75 and 1.35 < high < 1.75


def test_peg_friction_is_an_option_of_the_environments_and_zero_by_default():
    env = gym.make("dlo_env/DLODualEndpoint-v0", max_pegs=2, peg_friction=0.3)
    assert env.unwrapped.params.peg_friction == 0.3
    assert gym.make("dlo_env/DLOEndpoint-v0").unwrapped.params.peg_friction == 0.0
    env.reset(seed=0)
    assert all(shape.friction == 0.3 for shape in env.unwrapped.cord._peg_shapes)
    with pytest.raises(ValueError, match="CordParams.peg_friction must be >= 0"):
        gym.make("dlo_env/DLOEndpoint-v0", peg_friction=-0.1)
