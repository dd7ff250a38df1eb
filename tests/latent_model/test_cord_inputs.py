"""A transition model conditioned on the cord (TransitionModelConfig.cord_inputs)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from dlo_env import CordParams
from dlo_env.shapes import random_cord_shape
from latent_model.transition_model import TransitionModel, TransitionModelConfig, cord_features


@pytest.fixture(scope="module")
def shapes() -> np.ndarray:
    rng = np.random.default_rng(3)
    return np.stack([random_cord_shape(rng) for _ in range(6)]).astype(np.float32)


def _model(**kw) -> TransitionModel:
    torch.manual_seed(0)
    model = TransitionModel(TransitionModelConfig(width=16, depth=2, members=2, **kw),
                            device="cpu").eval()
    with torch.no_grad():  # outputs of full size, so that the cord's inputs show
        model.net.weights[-1].mul_(10.0)
    return model


def test_cord_features_are_log_ratios_to_the_default_cord():
    rows = np.array([[1.0, 0.01, 0.4, 0.1], [1.0, 0.02, 0.4, 0.1]])
    feats = cord_features(rows)
    assert np.array_equal(feats[0], np.zeros(4, np.float32))
    assert feats[1, 1] == pytest.approx(math.log(2))


def test_one_row_per_shape_predicts_what_one_cord_per_call_does(shapes):
    model = _model(cord_inputs=True)
    d = np.full((6, 4), 0.05, np.float32)
    stiff = CordParams(bending_stiffness=0.03, length=1.2)
    rows = np.array([[1.0, 0.01, 0.4, 0.1]] * 3 + [[1.2, 0.03, 0.4, 0.1]] * 3)
    mixed = model.predict(shapes, "both", d, params=rows)
    np.testing.assert_array_equal(mixed[:3], model.predict(shapes, "both", d)[:3])
    np.testing.assert_array_equal(mixed[3:], model.predict(shapes, "both", d, params=stiff)[3:])
    assert np.abs(mixed[3:] - model.predict(shapes, "both", d)[3:]).max() > 1e-4
    # The projection keeps each cord's own segment length.
    seg = np.linalg.norm(np.diff(mixed, axis=1), axis=-1)
    assert seg[:3].mean() == pytest.approx(1.0 / 19, rel=0.02)
    assert seg[3:].mean() == pytest.approx(1.2 / 19, rel=0.02)


def test_a_model_of_one_cord_takes_only_its_own(shapes):
    model = _model()
    d = np.full((6, 2), 0.05, np.float32)
    np.testing.assert_array_equal(model.predict(shapes, "head", d, params=CordParams()),
                                  model.predict(shapes, "head", d))
    with pytest.raises(ValueError, match="trained for one cord"):
        model.predict(shapes, "head", d, params=CordParams(friction=0.6))
    with pytest.raises(ValueError, match=r"params must be None, a CordParams, or positive"):
        _model(cord_inputs=True).predict(shapes, "head", d, params=np.ones((5, 4)))


def test_the_span_of_both_ends_is_the_cords(shapes):
    model = _model(cord_inputs=True)
    apart = np.zeros((1, 20, 2), np.float32)
    apart[0, :, 0] = np.linspace(-0.35, 0.35, 20)  # ends 70 cm apart
    pull = np.array([[-0.2, 0.0, 0.2, 0.0]], np.float32)  # 40 cm further apart
    short = model.reachable_moves(apart, "both", pull, params=CordParams(length=0.8))
    long = model.reachable_moves(apart, "both", pull, params=CordParams(length=1.3))
    assert np.abs(short).sum() < np.abs(long).sum()


def test_the_projection_holds_only_the_held_ends(shapes):
    model = _model()
    d = np.full((6, 2), 0.05, np.float32)
    raw = model.predict(shapes, "head", d, inextensible=False)
    projected = model.predict(shapes, "head", d)
    np.testing.assert_array_equal(projected[:, 0], raw[:, 0])  # the held head stays
    assert np.abs(projected[:, -1] - raw[:, -1]).max() > 1e-4  # the free tail may move
