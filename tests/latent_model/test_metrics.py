from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from dlo_env import shapes as S
from latent_model import metrics


def test_error_matches_dlo_env_shapes(cord_shapes):
    a, b = cord_shapes[:20], cord_shapes[20:40]
    ours = metrics.error(torch.from_numpy(a), torch.from_numpy(b)).numpy()
    assert np.allclose(ours, S.error(a, b), atol=1e-6)


def test_chain_statistics_match_dlo_env_shapes(cord_shapes):
    x = torch.from_numpy(cord_shapes)
    assert np.allclose(metrics.spacing_cv(x).numpy(), S.spacing_cv(cord_shapes), atol=1e-5)
    assert np.allclose(metrics.cord_length(x).numpy(), S.cord_length(cord_shapes), atol=1e-5)


def test_pairwise_error_of_a_translated_shape_is_the_translation(cord_shapes):
    a = torch.from_numpy(cord_shapes[:3])
    b = a + torch.tensor([0.03, 0.04])
    d = metrics.pairwise_error(a, b, chunk=2)
    assert d.shape == (3, 3)
    assert torch.allclose(torch.diagonal(d), torch.full((3,), 0.05), atol=1e-6)


def test_identical_sets_have_full_coverage_and_zero_mmd(cord_shapes):
    x = torch.from_numpy(cord_shapes[:50])
    cov, mmd = metrics.coverage_and_mmd(x, x)
    assert cov == 1.0
    assert mmd == pytest.approx(0.0, abs=1e-6)


def test_a_collapsed_generator_covers_one_reference_shape(cord_shapes):
    ref = torch.from_numpy(cord_shapes[:50])
    collapsed = ref[:1].repeat(100, 1, 1)
    cov, mmd = metrics.coverage_and_mmd(collapsed, ref, aligned=False)
    assert cov == 1 / 50
    expected = metrics.error(ref, ref[:1]).mean()
    assert mmd == pytest.approx(float(expected), rel=1e-5)


def test_one_nn_accuracy_is_one_for_separate_sets_and_zero_for_twins(cord_shapes):
    ref = torch.from_numpy(cord_shapes[:40])
    far = ref + 5.0  # further from every reference shape than any two reference shapes are apart
    assert metrics.one_nn_accuracy(far, ref, aligned=False) == 1.0
    # Pose-aligned, a translated copy is the same shape: each point's nearest neighbour is its
    # twin from the other set, so the classifier is always wrong.
    assert metrics.one_nn_accuracy(far, ref, aligned=True) == 0.0
    assert metrics.one_nn_accuracy(ref + 0.001, ref, aligned=False) == 0.0


def test_success_rate_counts_errors_up_to_one_centimetre():
    assert metrics.success_rate(torch.tensor([0.0, 0.01, 0.0101, 0.5])) == 0.5


def test_set_quality_reports_length_error_relative_to_the_rest_length(cord_shapes):
    ref = torch.from_numpy(cord_shapes[:30])
    q = metrics.set_quality(ref * 1.1, ref, cord_length_m=1.0, aligned=False)
    assert q.length == pytest.approx(1.1, rel=1e-3)
    assert q.length_error == pytest.approx(0.1, rel=1e-2)
    assert math.isfinite(q.spacing_cv)


def test_metrics_reject_single_shapes():
    with pytest.raises(ValueError, match=r"\(B, n, 2\)"):
        metrics.coverage_and_mmd(torch.zeros(20, 2), torch.zeros(3, 20, 2))


def test_grouped_quality_breaks_down_the_whole_set_metrics(cord_shapes):
    ref = torch.from_numpy(cord_shapes[:60])
    groups = torch.tensor([0] * 20 + [1] * 40)
    # A generator that draws only shapes of group 0 (and slightly moved copies of them).
    gen = torch.cat([ref[:20], ref[:20] + 0.001])
    broken = metrics.grouped_quality(gen, ref, groups, aligned=False)
    cov, mmd = metrics.coverage_and_mmd(gen, ref, aligned=False)
    assert broken[0][0] == 1.0 and broken[1][0] == 0.0
    assert broken[0][1] == pytest.approx(0.0, abs=1e-6) and broken[1][1] > 0.0
    # Whole-set COV and MMD are the reference-weighted means of the groups'.
    assert cov == pytest.approx((20 * broken[0][0] + 40 * broken[1][0]) / 60)
    assert mmd == pytest.approx((20 * broken[0][1] + 40 * broken[1][1]) / 60, rel=1e-5)
    with pytest.raises(ValueError, match="groups must have shape"):
        metrics.grouped_quality(gen, ref, groups[:5])
