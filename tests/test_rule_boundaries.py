"""The exact gear-set rule at its boundary and each objective's sense, wherever a source reads them (issue 54,
part 3): a planet-teeth bound moved by one (``>= 9`` to ``> 9``) or an objective's sense flipped (``f_max``
minimised) fails a test here by name, not only a golden reference.

The expectations are written out here, independently of :mod:`hevlib.design` (SPEC section 5: planet teeth
``(n_r - n_s) / 2`` whole and at least 9, ``n_r + n_s`` divisible by the 4 planets; SPEC section 3: ``v_max`` and
``f_max`` maximised, every other objective minimised), so a change there cannot carry its own test along.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from pymoo.util.dominator import Dominator
from test_optimise import SPACE, stand_in_mass_kg

from hevlib.design import DESIGN_VARS, OBJECTIVES, buildable_gear_sets, gear_set_buildable
from hevlib.indicators import Normalisation, hypervolume_exact, nondominated_mask, to_minimisation
from hevlib.judging import objective_matrix
from hevlib.optimise.bayesopt import MixedSpace
from hevlib.optimise.problem import HevProblem, _Reformulated, _repaired, admissible_lhs
from hevlib.recommend import minimisation
from hevlib.screen import buildable_gear_set, passing
from hevlib.surrogates.gp import GaussianProcesses
from hevlib.surrogates.transform import LogTargets

#: (n_r, n_s) with 9 planet teeth, (53 - 35) / 2, and 53 + 35 = 88 = 4 x 22: the smallest planet the rule admits.
PLANET_9 = (53, 35)
#: 8 planet teeth, (50 - 34) / 2, and 50 + 34 = 84 = 4 x 21: one tooth less, refused.
PLANET_8 = (50, 34)
#: 9 planet teeth but 54 + 36 = 90, not a multiple of the 4 planets: refused.
NOT_ASSEMBLABLE = (54, 36)
#: SPEC section 3: the maximised objectives (every other one is minimised).
MAXIMISED = {"v_max", "f_max"}

J_R, J_S = DESIGN_VARS.index("n_r"), DESIGN_VARS.index("n_s")


def _designs(*gear_sets: tuple[int, int]) -> np.ndarray:
    """One admissible design (stand-in mass 1114 kg) per gear set."""
    X = np.tile([30.0, 30.0, 10.0, 3.0, 20.0, 0.0, 0.0], (len(gear_sets), 1))
    X[:, [J_R, J_S]] = np.array(gear_sets, dtype=float)
    return X


def _rules_problem(model=None) -> HevProblem:
    return HevProblem(model, SPACE, stand_in_mass_kg, 1195.0, gen_below_motor=True, buildable_gear_set=True)


# ------------------------------------------------------------------------------------- the gear-set rule
def test_the_rule_admits_nine_planet_teeth_and_refuses_eight():
    for (n_r, n_s), ok in ((PLANET_9, True), (PLANET_8, False), (NOT_ASSEMBLABLE, False)):
        assert bool(gear_set_buildable(np.array([n_r]), np.array([n_s]))[0]) is ok, (n_r, n_s)
    pairs = {tuple(p) for p in buildable_gear_sets(SPACE).tolist()}
    assert PLANET_9 in pairs and PLANET_8 not in pairs and NOT_ASSEMBLABLE not in pairs


def test_every_optimisers_repair_keeps_the_boundary_set_and_moves_the_one_below():
    """NSGA-III, MOEA/D, the GA and the oracle repair through the problem (``_repaired``); the Latin hypercubes
    of the judged scale and the benchmark's lhs source draw through it (``admissible_lhs``)."""
    problem = _rules_problem()
    X = _designs(PLANET_9, PLANET_8, NOT_ASSEMBLABLE)
    R = _repaired(problem, X)
    np.testing.assert_array_equal(R[0], X[0])  # admissible at the bound: untouched
    for i in (1, 2):
        assert tuple(R[i, [J_R, J_S]].astype(int)) != tuple(X[i, [J_R, J_S]].astype(int))
        assert gear_set_buildable(R[i : i + 1, J_R].astype(int), R[i : i + 1, J_S].astype(int))[0]
    drawn = admissible_lhs(problem, SPACE, 400, 3)
    seen = {tuple(p) for p in drawn[:, [J_R, J_S]].astype(int).tolist()}
    assert PLANET_8 not in seen and NOT_ASSEMBLABLE not in seen
    assert gear_set_buildable(drawn[:, J_R].astype(int), drawn[:, J_S].astype(int)).all()


def test_the_bayesian_sources_search_the_boundary_set_and_not_the_one_below():
    sets = {tuple(p) for p in MixedSpace.of(_rules_problem(), SPACE).gear_sets.astype(int).tolist()}
    assert PLANET_9 in sets and PLANET_8 not in sets and NOT_ASSEMBLABLE not in sets


def test_the_screen_passes_the_boundary_set_and_fails_the_one_below():
    X = _designs(PLANET_9, PLANET_8, NOT_ASSEMBLABLE)
    table = pd.DataFrame({"n_r": X[:, J_R], "n_s": X[:, J_S]})
    assert passing(table, buildable_gear_set().expr()).tolist() == [True, False, False]


# ------------------------------------------------------------------------------------ objective senses
#: Plausible objectives in OBJECTIVES order (m_veh, fc, accel_dev, hc, co, nox, e_l, speed_dev, diff_soc, v_max,
#: f_max).
Y0 = np.array([1150.0, 4.5, 8.0, 0.05, 0.4, 0.03, 40.0, 0.2, 0.05, 160.0, 3.0])


def _better_in(k: str) -> np.ndarray:
    """Two designs alike but in ``k``, where the first is better by the SPEC's sense (larger where maximised)."""
    a, b = Y0.copy(), Y0.copy()
    j = OBJECTIVES.index(k)
    a[j] = Y0[j] * (1.1 if k in MAXIMISED else 0.9)
    return np.vstack([a, b])


class _Fixed:
    """A model that predicts the given objectives, row for row."""

    def __init__(self, Y: np.ndarray):
        self.Y = Y

    def predict(self, X):
        return self.Y[: len(X)]


def test_the_objectives_and_their_senses_are_the_specs():
    assert len(OBJECTIVES) == len(Y0) == 11
    assert set(OBJECTIVES) >= MAXIMISED


@pytest.mark.parametrize("k", OBJECTIVES)
def test_a_design_better_in_one_objective_dominates_where_the_indicators_read_it(k):
    Y = _better_in(k)
    F = to_minimisation(Y)
    assert nondominated_mask(F).tolist() == [True, False]
    # the merged fronts, the judged scale and every hypervolume read the simulated columns through this
    sim = pd.DataFrame({f"sim_{n}": Y[:, i] for i, n in enumerate(OBJECTIVES)})
    np.testing.assert_array_equal(objective_matrix(sim), F)
    # the recommendation's knee and groups
    np.testing.assert_array_equal(minimisation(sim, OBJECTIVES, "sim_"), F)
    norm = Normalisation.from_points(F)
    ref = np.full(len(OBJECTIVES), 1.1)
    assert hypervolume_exact(norm(F[:1]), ref) > hypervolume_exact(norm(F[1:]), ref)


@pytest.mark.parametrize("k", OBJECTIVES)
def test_a_design_better_in_one_objective_dominates_where_the_optimisers_read_it(k):
    Y = _better_in(k)
    X = _designs(PLANET_9, PLANET_9)
    problem = _rules_problem(_Fixed(Y))
    F = np.asarray(problem.evaluate(X, return_values_of=["F"]), dtype=float)
    assert Dominator.get_relation(F[0], F[1]) == 1  # pymoo minimises: the first dominates
    # the weighted-sum GA's scalarised objective: less is better, for any positive weights
    norm = Normalisation.from_points(F)
    ws = _Reformulated(problem, norm, weights=np.full(len(OBJECTIVES), 1.0 / len(OBJECTIVES)))
    F_ws = np.asarray(ws.evaluate(X, return_values_of=["F"]), dtype=float).ravel()
    assert F_ws[0] < F_ws[1]
    # the Gaussian processes of the Bayesian sources (BoTorch maximises): larger is better
    gp = GaussianProcesses(SPACE)
    gp.transform_ = LogTargets.fit((), Y, what="objectives")  # what fit() sets before fitting the models
    T = gp.to_model_space(Y)
    j = OBJECTIVES.index(k)
    assert T[0, j] > T[1, j]
