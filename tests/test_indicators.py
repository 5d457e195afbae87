"""Quality indicators: the exact hypervolume against hand-computed values, Monte Carlo against exact on the
default pipeline's fronts, the one hypervolume function's choice, normalisation, IGD."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hevlib.indicators import Normalisation, hypervolume, hypervolume_exact, hypervolume_mc, igd

FRONTS = Path(__file__).parent / "data" / "hv_fronts.npz"


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


# ------------------------------------------------------------------------- exact, by hand
def test_exact_hypervolume_of_a_hand_computed_2d_front():
    # staircase up to (1, 1): [0.1, 1] x [0.8, 1] + [0.4, 1] x [0.5, 0.8] + [0.7, 1] x [0.2, 0.5]
    F = np.array([[0.1, 0.8], [0.4, 0.5], [0.7, 0.2]])
    assert hypervolume_exact(F, 1.0) == pytest.approx(0.9 * 0.2 + 0.6 * 0.3 + 0.3 * 0.3, abs=1e-15)
    # a dominated point, a duplicate and a point beyond the reference change nothing
    more = np.vstack([F, [0.5, 0.9], F[:1], [1.2, 0.0]])
    assert hypervolume_exact(more, 1.0) == pytest.approx(0.45, abs=1e-15)


def test_exact_hypervolume_of_a_hand_computed_3d_front():
    # two boxes up to (1, 1, 1): a = [0.5, 1] x [0, 1] x [0, 1] ... from (0.5, 0, 0): 0.5 * 1 * 1
    # b from (0, 0.5, 0.5): 1 * 0.5 * 0.5 = 0.25; overlap from (0.5, 0.5, 0.5): 0.125 -> 0.625
    F = np.array([[0.5, 0.0, 0.0], [0.0, 0.5, 0.5]])
    assert hypervolume_exact(F, 1.0) == pytest.approx(0.625, abs=1e-15)
    # inclusion-exclusion over three points
    G = np.array([[0.2, 0.6, 0.4], [0.6, 0.2, 0.4], [0.4, 0.4, 0.1]])
    boxes = [np.prod(1.0 - g) for g in G]
    pairs = [np.prod(1.0 - np.maximum(G[i], G[j])) for i, j in ((0, 1), (0, 2), (1, 2))]
    triple = np.prod(1.0 - G.max(axis=0))
    assert hypervolume_exact(G, 1.0) == pytest.approx(sum(boxes) - sum(pairs) + triple, abs=1e-15)
    assert hypervolume_exact(G, [1.0, 1.0, 1.0]) == hypervolume_exact(G, 1.0)


# ------------------------------------------------------------- Monte Carlo against exact
def test_mc_agrees_with_exact_within_its_standard_error_on_the_pipelines_fronts():
    """Every front in ``hv_fronts.npz``: screen-passing designs of each source's fronts (rounds 0-4) of the
    default pipeline, normalised as reports/pareto.json (the first 50 rows of each: exact in 0.2 s). The seeded
    estimate lies within 2 standard errors of the exact value on each, and within one on most."""
    fronts = np.load(FRONTS)
    z = []
    for name in fronts.files:
        F = fronts[name]
        exact = hypervolume_exact(F, 1.1)
        est, se = hypervolume_mc(F, 1.1, n_samples=200_000, seed=7)
        assert 0 < se < 0.02 * exact, name
        z.append((est - exact) / se)
    z = np.abs(np.array(z))
    assert len(z) == 13 and np.all(z < 2.0) and np.mean(z < 1.0) >= 0.6, z


def test_the_one_hypervolume_is_exact_up_to_its_limit_and_monte_carlo_beyond():
    F = np.load(FRONTS)["nsga3_round1"]  # 50 non-dominated rows
    exact = hypervolume(F, 1.1, n_samples=50_000, seed=7, exact_max_points=50)
    assert exact.method == "exact" and exact.se == 0.0 and exact.n_points == 50 and exact.n_samples == 0
    assert exact.value == hypervolume_exact(F, 1.1)
    mc = hypervolume(F, 1.1, n_samples=50_000, seed=7, exact_max_points=49)
    assert mc.method == "monte_carlo" and mc.n_samples == 50_000 and mc.n_points == 50
    assert (mc.value, mc.se) == hypervolume_mc(F, 1.1, n_samples=50_000, seed=7)
    assert abs(mc.value - exact.value) < 3 * mc.se
    # the choice counts non-dominated rows below the reference only, never the clock
    padded = np.vstack([F, F + 0.01, np.full((5, F.shape[1]), 2.0)])
    again = hypervolume(padded, 1.1, n_samples=50_000, seed=7, exact_max_points=50)
    assert again.method == "exact" and again.value == exact.value
    assert set(exact.describe()) == {"method", "value", "se", "n_points", "n_samples"}
    none = hypervolume(np.full((3, 4), 2.0), 1.1, n_samples=100, seed=0, exact_max_points=10)
    assert (none.value, none.method, none.n_points) == (0.0, "empty", 0)


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
