"""The designs comparison script (benchmarks/transition_designs.py) runs at any model setting."""

from __future__ import annotations

import numpy as np
import pytest
from scripts import load_script

from dlo_env.shapes import random_cord_shape
from latent_model import ShapeModel
from latent_model.transition_model import TransitionModelConfig


@pytest.fixture(scope="module")
def designs():
    module = load_script("benchmarks/transition_designs.py")
    module.LatentTransitionModel.shape_model = ShapeModel.load_or_pretrained(None, "cpu")
    return module


@pytest.mark.parametrize("rim_targets", [1, 2])
def test_the_latent_design_predicts_every_grasp(designs, rim_targets):
    config = TransitionModelConfig(width=16, depth=1, members=2, rim_targets=rim_targets)
    model = designs.LatentTransitionModel(config, device="cpu").eval()
    rng = np.random.default_rng(0)
    shapes = np.stack([random_cord_shape(rng) for _ in range(3)])
    for end, width in (("head", 2), ("tail", 2), ("both", 4)):
        out = model.predict(shapes, end, np.full((3, width), 0.05, np.float32))
        assert out.shape == shapes.shape and np.isfinite(out).all()
    assert designs.DESIGN_MODEL.rim_targets == 1 and not designs.DESIGN_MODEL.mirror
