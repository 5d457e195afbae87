"""Quality indicators: Monte Carlo hypervolume against the exact one, normalisation, IGD."""

from __future__ import annotations

import numpy as np
import pytest

from hevlib.indicators import Normalisation, hypervolume_exact, hypervolume_mc, igd


def _sphere_front(n: int, m: int, seed: int) -> np.ndarray:
    """Points on the positive unit sphere in m objectives (a concave front, like DTLZ2's)."""
    z = np.abs(np.random.default_rng(seed).normal(size=(n, m)))
    return z / np.linalg.norm(z, axis=1, keepdims=True)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_mc_hypervolume_agrees_with_exact_in_3d(seed):
    F = _sphere_front(30, 3, seed)
    exact = hypervolume_exact(F, 1.1)
    est, se = hypervolume_mc(F, 1.1, n_samples=100_000, seed=seed)
    assert 0 < se < 0.01 * exact
    assert abs(est - exact) < 4 * se


def test_mc_hypervolume_is_seeded_and_exact_for_a_box():
    F = np.array([[0.2, 0.5, 0.1, 0.3]])
    a = hypervolume_mc(F, 1.0, n_samples=5_000, seed=3)
    assert a == hypervolume_mc(F, 1.0, n_samples=5_000, seed=3)
    assert a != hypervolume_mc(F, 1.0, n_samples=5_000, seed=4) or a[1] == 0
    # one point: its box is the whole sampling box, so the estimate is exact and the error zero
    assert a[0] == pytest.approx(np.prod(1.0 - F[0]))
    assert a[1] == 0.0


def test_mc_hypervolume_ignores_points_beyond_the_reference_and_dominated_points():
    F = np.array([[0.2, 0.2], [0.5, 0.5], [1.5, 0.0]])  # 2nd dominated, 3rd beyond the reference
    exact = hypervolume_exact(F, 1.0)
    assert exact == pytest.approx(0.64)
    est, se = hypervolume_mc(F, 1.0, n_samples=20_000, seed=0)
    assert est == pytest.approx(0.64) and se == 0.0
    assert hypervolume_mc(np.array([[1.2, 0.1]]), 1.0, n_samples=100, seed=0) == (0.0, 0.0)


def test_mc_hypervolume_grows_with_a_better_front():
    F = _sphere_front(50, 6, 0)
    worse, _ = hypervolume_mc(F + 0.05, 1.2, n_samples=50_000, seed=1)
    better, se = hypervolume_mc(F, 1.2, n_samples=50_000, seed=1)
    assert better > worse + 3 * se


def test_normalisation_maps_ideal_to_zero_nadir_to_one_and_keeps_constant_objectives_finite():
    F = np.array([[1.0, 10.0, 5.0], [3.0, 30.0, 5.0], [2.0, 20.0, 5.0]])
    norm = Normalisation.from_points(F)
    Z = norm(F)
    np.testing.assert_allclose(Z[:, :2], [[0, 0], [1, 1], [0.5, 0.5]])
    np.testing.assert_allclose(Z[:, 2], 0.0)  # constant objective: span 1, so 0 at the ideal
    assert norm(np.array([[1.0, 10.0, 6.0]]))[0, 2] == 1.0
    with pytest.raises(ValueError, match="nadir below ideal"):
        Normalisation(np.array([1.0]), np.array([0.0]))
    with pytest.raises(ValueError, match="objective 1 has no finite value"):
        Normalisation.from_points(np.array([[1.0, np.nan]]))


def test_igd_is_zero_on_the_reference_and_grows_with_distance():
    R = _sphere_front(200, 4, 0)
    assert igd(R, R) == pytest.approx(0.0)
    assert igd(1.1 * R, R) == pytest.approx(0.1, rel=1e-6)
    assert igd(R[:1], R) > igd(R[:50], R) > 0
    with pytest.raises(ValueError, match="same m"):
        igd(R[:, :3], R)
