"""Specification: the validators of planners raise ``dlo_env.errors.InputError``."""

from __future__ import annotations

import pytest

from dlo_env.errors import InputError
from planners.cem import CEMConfig
from planners.latent_tree import TreeConfig
from planners.straight_line import StraightLinePolicy


@pytest.mark.parametrize("build", [
    lambda: TreeConfig(goal_bias=2.0),
    lambda: TreeConfig(grasp="middle"),
    lambda: CEMConfig(elites=10**6),
    lambda: StraightLinePolicy(max_step=0.0),
    lambda: StraightLinePolicy(grasp="middle"),
])
def test_a_planner_config_or_argument_check_raises_an_input_error(build):
    with pytest.raises(InputError):
        build()
