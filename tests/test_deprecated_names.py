"""Specification of the deprecated names of arguments and fields: each still works, with a
``DeprecationWarning`` that names the call and points at the caller's line, and giving it with
its new name is refused; one message for all of them."""

from __future__ import annotations

import numpy as np
import pytest
from toy_models import ToyHeadModel

from dlo_bench import evaluate
from dlo_env.shapes import random_cord_shape
from latent_model import TransitionModel, TransitionModelConfig
from planners import LatentTreePlanner, StraightLinePolicy, TreeConfig

SHAPE = random_cord_shape(np.random.default_rng(0))
TINY = TransitionModel(TransitionModelConfig(width=8, depth=1, members=2), device="cpu")
ENV = "dlo_env/DLOEndpoint-v0"
#: (name in the messages, old, new, the call with the old name, with both names)
CASES = [
    ("TreeConfig", "end", "grasp", lambda: TreeConfig(end="tail"),
     lambda: TreeConfig(end="tail", grasp="tail")),
    ("LatentTreePlanner", "end", "grasp", lambda: LatentTreePlanner(ToyHeadModel(), end="tail"),
     lambda: LatentTreePlanner(ToyHeadModel(), end="tail", grasp="tail")),
    ("TransitionModel.predict", "end", "grasp",
     lambda: TINY.predict(SHAPE, end="tail", displacement=[0.05, 0.0]),
     lambda: TINY.predict(SHAPE, "tail", [0.05, 0.0], end="tail")),
    ("TransitionModel.reachable_moves", "end", "grasp",
     lambda: TINY.reachable_moves(SHAPE[None], end="tail", displacement=np.zeros((1, 2))),
     lambda: TINY.reachable_moves(SHAPE[None], "tail", np.zeros((1, 2)), end="tail")),
    ("evaluate", "env_id", "env",
     lambda: evaluate(StraightLinePolicy(), env_id=ENV, difficulty=1, episodes=1,
                      fidelity=False),
     lambda: evaluate(StraightLinePolicy(), ENV, env_id=ENV)),
]


@pytest.mark.parametrize(("name", "old", "new", "call", "both"), CASES,
                         ids=[case[0] for case in CASES])
def test_an_old_name_warns_at_the_callers_line_and_both_names_are_refused(
        name, old, new, call, both):
    with pytest.warns(DeprecationWarning) as caught:
        call()
    warning = caught.pop(DeprecationWarning)
    assert str(warning.message) == f"{name}({old}=...) is deprecated: use {new}=..."
    assert warning.filename == __file__
    with pytest.raises(ValueError) as info:
        both()
    assert str(info.value) == f"give {name}({new}=...) ({old} is its deprecated name), not both"
