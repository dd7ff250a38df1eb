"""Shared tiny fixtures for the latent_model tests (everything on CPU, seconds at most)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from dlo_env.shapes import random_cord_shape
from latent_model.config import ModelConfig, TrainConfig


@pytest.fixture(autouse=True)
def _one_thread():
    # Tiny networks run faster on one thread, and other jobs share the machine.
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


@pytest.fixture(scope="session")
def cord_shapes() -> np.ndarray:
    """300 random cord shapes of the default cord (20 points, 1 m), float32."""
    rng = np.random.default_rng(0)
    return np.stack([random_cord_shape(rng) for _ in range(300)])


@pytest.fixture
def tiny_config() -> ModelConfig:
    return ModelConfig(width=32, depth=2)


@pytest.fixture
def tiny_train_config() -> TrainConfig:
    return TrainConfig(batch_size=64, encoder_batch_size=64, d_steps=1, eval_every=1000,
                       eval_reference=40, eval_inversion=10, threads=1)
