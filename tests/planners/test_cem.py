"""The CEM planner shared by physics-mpc and latent-mpc: its sampling and stopping rules."""

from __future__ import annotations

import numpy as np
import pytest

from planners.cem import CEMConfig, CEMPolicy


class Recording(CEMPolicy):
    """Scores every candidate by its distance from zero displacement; records what it sampled."""

    def __init__(self, config: CEMConfig, success_threshold: float = 0.02) -> None:
        super().__init__(None, "head", 0.02, success_threshold, config)
        self.batches: list[np.ndarray] = []

    def _score(self, shape, goal, candidates):
        self.batches.append(candidates.copy())
        return np.linalg.norm(candidates.reshape(len(candidates), -1), axis=1) + 1.0

    def _execute(self, plan):
        return self._actions(plan)


def _shapes(offset: float) -> tuple[np.ndarray, np.ndarray]:
    goal = np.stack([np.linspace(-0.5, 0.5, 20), np.zeros(20)], axis=1)
    return goal + np.array([0.0, offset]), goal


@pytest.mark.parametrize(("focus", "offset", "expected"), [
    (0.0, 0.01, 0.08),     # off: always init_std
    (2.0, 0.01, 0.02),     # twice the current error (1 cm)
    (2.0, 0.001, 0.005),   # never below min_std
    (2.0, 0.30, 0.08),     # never above init_std
])
def test_focus_scales_the_first_sampling_spread_with_the_current_error(focus, offset, expected):
    config = CEMConfig(samples=4000, elites=10, iterations=1, focus=focus, max_move=10.0)
    policy = Recording(config)
    policy.plan(*_shapes(offset))
    first = policy.batches[0][1:]  # candidate 0 is the mean itself
    spread = (first - first.mean(axis=0)).std()
    assert spread == pytest.approx(expected, rel=0.05)


def test_stop_fraction_is_a_fraction_of_the_threshold():
    # Every candidate scores 1.0 or more: no early stop below the threshold's fraction...
    policy = Recording(CEMConfig(iterations=4, stop_fraction=0.5), success_threshold=0.02)
    policy.plan(*_shapes(0.05))
    assert len(policy.batches) == 4
    # ...and a threshold whose half is above every score stops after the first iteration.
    policy = Recording(CEMConfig(iterations=4, stop_fraction=0.5), success_threshold=100.0)
    policy.plan(*_shapes(0.05))
    assert len(policy.batches) == 1


@pytest.mark.parametrize("field", ["focus", "stop_fraction"])
def test_negative_fields_are_refused(field):
    with pytest.raises(ValueError, match=field):
        CEMConfig(**{field: -1.0})


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"min_std": 0.1}, "min_std"),           # above init_std (0.08)
    ({"stop_fraction": 1.5}, "stop_fraction"),
])
def test_inconsistent_fields_are_refused(kwargs, field):
    with pytest.raises(ValueError, match=field):
        CEMConfig(**kwargs)


def test_settle_actions_must_be_a_whole_number():
    from planners.latent_mpc import LatentMPCConfig
    from planners.physics_mpc import PhysicsMPCConfig

    for kind in (LatentMPCConfig, PhysicsMPCConfig):
        with pytest.raises(ValueError, match="settle_actions must be an int >= 0"):
            kind(settle_actions=2.5)


def test_a_policy_built_for_another_threshold_is_refused():
    import gymnasium as gym

    import dlo_env  # noqa: F401
    from planners.physics_mpc import PhysicsMPCPolicy

    policy = PhysicsMPCPolicy.for_env(gym.make("dlo_env/DLOEndpoint-v0"))
    with pytest.raises(ValueError, match="success_threshold"):
        policy.check_env(gym.make("dlo_env/DLOEndpoint-v0", success_threshold=0.005))


def test_a_policy_built_for_another_success_metric_is_refused():
    import gymnasium as gym

    import dlo_env  # noqa: F401
    from planners.physics_mpc import PhysicsMPCPolicy

    env = gym.make("dlo_env/DLOEndpoint-v0", success_metric="direction_free_error")
    assert PhysicsMPCPolicy.for_env(env).success_metric == "direction_free_error"
    with pytest.raises(ValueError, match="success_metric"):
        PhysicsMPCPolicy.for_env(gym.make("dlo_env/DLOEndpoint-v0")).check_env(env)


def test_far_moves_lengthen_the_horizon_only_far_from_the_goal_and_for_their_grasps():
    config = CEMConfig(moves=2, far_moves=5, far_error=0.06, samples=8, elites=2, iterations=1)
    policy = Recording(config)
    far, goal = _shapes(0.10)
    plan, _ = policy.plan(far, goal)
    assert plan.shape == (5, 1, 2) and policy.batches[-1].shape[1] == 5
    # The warm start of the next, near plan is the rest of the far one, cut to 2 moves.
    rest = policy._mean.copy()
    near, _ = _shapes(0.01)
    plan, _ = policy.plan(near, goal)
    assert plan.shape == (2, 1, 2)
    assert np.array_equal(policy.batches[-1][0], rest[:2])  # candidate 0 is the mean
    # And back out: a near plan's rest, padded with still moves to 5.
    rest = policy._mean.copy()
    policy.plan(far, goal)
    assert np.array_equal(policy.batches[-1][0], np.concatenate([rest, np.zeros((3, 1, 2))]))
    # Off for a grasp not in far_grasps, and with far_moves 0.
    other = CEMConfig(moves=2, far_moves=5, far_grasps=("both",), samples=8, elites=2,
                      iterations=1)
    assert Recording(other).horizon(far, goal) == 2
    assert Recording(CEMConfig(moves=2, samples=8, elites=2)).horizon(far, goal) == 2


@pytest.mark.parametrize("value", [("hand",), ["head"]])
def test_far_grasps_are_checked(value):
    with pytest.raises(ValueError, match="far_grasps"):
        CEMConfig(far_grasps=value)


def test_offer_straight_scores_the_straight_plan_in_every_iteration():
    shape, goal = _shapes(0.05)  # the head is 5 cm from the goal's: one move reaches it
    policy = Recording(CEMConfig(samples=8, elites=2, iterations=3, moves=3,
                                 offer_straight=True))
    policy.plan(shape, goal)
    straight = np.zeros((3, 1, 2))
    straight[0, 0] = goal[0] - shape[0]
    for batch in policy.batches:
        np.testing.assert_allclose(batch[1], straight)
    # A far goal is reached in as many equal moves as max_move needs; direction-free scoring
    # is offered the reversed goal too.
    far = goal + np.array([0.6, 0.0])
    plans = Recording(CEMConfig(moves=3, max_move=0.25))._straight_plans(shape, far, 3)
    np.testing.assert_allclose(plans[0], [[[0.2, -0.05 / 3]]] * 3)
    free = Recording(CEMConfig(moves=3))
    free.success_metric = "direction_free_error"
    assert len(free._straight_plans(shape, goal, 3)) == 2
    # Off (the default): candidate 1 is a sample.
    policy = Recording(CEMConfig(samples=8, elites=2, iterations=1, moves=3))
    policy.plan(shape, goal)
    assert not np.allclose(policy.batches[0][1], straight)


def test_choose_is_offered_the_best_plans_scored_best_first():
    class Keeping(Recording):
        keep = 3

        def _choose(self, shape, goal, plans, errors):
            self.offered = (plans.copy(), errors.copy())
            return plans[-1].copy(), float(errors[-1])

    policy = Keeping(CEMConfig(samples=16, elites=4, iterations=2))
    plan, err = policy.plan(*_shapes(0.05))
    plans, errors = policy.offered
    assert len(plans) == 3 and np.all(np.diff(errors) >= 0)
    scored = np.concatenate(policy.batches)
    best = np.sort(np.linalg.norm(scored.reshape(len(scored), -1), axis=1) + 1.0)[:3]
    np.testing.assert_allclose(errors, best)
    assert err == errors[-1] and np.array_equal(plan, plans[-1])


def test_settings_leave_later_fields_out_at_their_defaults():
    from planners.cem import settings_repr
    from planners.latent_mpc import LatentMPCConfig

    plain = settings_repr(LatentMPCConfig())
    assert "offer_straight" not in plain and "verify" not in plain
    assert plain.startswith("LatentMPCConfig(moves=3, samples=256,") and "seed=0" in plain
    changed = settings_repr(LatentMPCConfig(offer_straight=True, verify=2))
    assert "offer_straight=True" in changed and "verify=2" in changed
    assert "verify_settle" not in changed
    assert settings_repr("x") == repr("x")
