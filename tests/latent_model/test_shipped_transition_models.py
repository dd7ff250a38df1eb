"""The shipped transition models: each loads, is small, and is what the agents pick."""

from __future__ import annotations

import gymnasium as gym
import pytest

import dlo_env  # noqa: F401  (registers the environments)
from dlo_bench.agents import build_agent
from dlo_bench.paths import transition_model_file
from latent_model.transition_model import TransitionModel, pretrained_file


@pytest.mark.parametrize("cords, pegs", [(False, False), (True, False), (False, True)])
def test_each_shipped_model_loads_with_its_mean_network_and_its_inputs(cords, pegs):
    path = transition_model_file(None, cords=cords, pegs=pegs)
    assert path.name == pretrained_file(cords, pegs) and path.stat().st_size < 5e6
    model = TransitionModel.load_pretrained("cpu", cords=cords, pegs=pegs)
    assert model.mean_net is not None
    assert model.config.cord_inputs == cords
    assert (model.config.peg_reach > 0) == pegs
    assert TransitionModel.load_or_pretrained(None, "cpu", cords=cords,
                                              pegs=pegs).config == model.config
    with pytest.raises(ValueError, match="both of several cords and of pegs"):
        pretrained_file(cords=True, pegs=True)


@pytest.mark.parametrize("name", ["latent-mpc", "latent-tree-kino"])
def test_the_planners_pick_the_model_that_sees_pegs_where_pegs_are_observed(name):
    with_pegs = gym.make("dlo_env/DLOEndpoint-v0", max_pegs=4)
    plain = gym.make("dlo_env/DLOEndpoint-v0")

    def model_of(policy):
        planner = getattr(policy, "planner", None)
        return policy.model if planner is None else planner.transition_model

    assert model_of(build_agent(name, with_pegs)).config.peg_reach > 0
    assert model_of(build_agent(name, plain)).config.peg_reach == 0


def test_the_model_fine_tuned_for_the_letters_cord_ships_and_latent_mpc_takes_it_there():
    from dlo_env.cord import CordParams
    from dlo_env.designed_suites import designed_suite_cord
    from latent_model.transition_model import CORD_MODEL_FILES, CORDS_MODEL_FILE

    letters = designed_suite_cord("shapes-letters")
    name = pretrained_file(cords=True, cord=letters)
    assert name in CORD_MODEL_FILES and name != CORDS_MODEL_FILE
    assert pretrained_file(cords=True, cord=CordParams()) == CORDS_MODEL_FILE
    assert pretrained_file(cord=letters) == "transition.pt"  # a one-cord model: no cord picked
    path = transition_model_file(None, cords=True, cord=letters)
    assert path.name == name and path.stat().st_size < 5e6
    model = TransitionModel.load_pretrained("cpu", cords=True, cord=letters)
    assert model.config.cord_inputs and model.mean_net is not None
    model.check_env_cord(letters)
    from latent_model.transition_model import trained_ranges

    env = gym.make("dlo_env/DLOEndpoint-v0", params=letters)
    policy = build_agent("latent-mpc", env)
    assert policy.cord == letters
    point = {k: (v, v) for k, v in CORD_MODEL_FILES[name].items()}
    assert trained_ranges(policy.model.info) == trained_ranges(model.info) == point
    adaptive = build_agent("latent-mpc-adaptive", env)  # fits the cord: the model of them all
    assert trained_ranges(adaptive.model.info)["bending_stiffness"] == (0.003, 0.03)
