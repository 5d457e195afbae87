"""The sizing problem the optimisers see (SPEC section 8): seven variables, eleven minimised objectives and
the constraints, on any model of the car (a surrogate, or the simulator itself: :class:`SimulatorModel`),
plus the one repair that keeps the integer variables whole and the reformulated views MOEA/D and the
weighted-sum GA need.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable

import numpy as np
import pandas as pd
from pymoo.core.problem import Problem
from pymoo.core.repair import Repair

from hevlib import screen
from hevlib.design import (
    DESIGN_VARS,
    INTEGER_MASK,
    OBJECTIVES,
    DesignSpace,
    buildable_gear_sets,
    nearest_gear_set,
)
from hevlib.doe import lhs_designs
from hevlib.indicators import Normalisation, to_minimisation

#: Objectives (minimisation form) of a design that breaks an exact rule and so was never evaluated.
NOT_EVALUATED = 1e12


class HevProblem(Problem):
    """Size the hybrid on a surrogate: 7 variables, 11 minimised objectives, the mass constraint and,
    optionally, the screening rules as constraints.

    ``surrogate`` is any :class:`hevlib.surrogates.base.Surrogate` (``predict(X) -> (n, 11)`` in natural
    units; ``predict_std`` is used when present); ``mass_kg`` maps ``X`` (n, 7) to the exact test mass
    (n,) (``Simulator.mass_kg``). The whole population is evaluated in one call of each.

    Constraints, all ``G <= 0`` feasible and dimensionless (violations add up on one scale), each the
    constraint form of the screen's rule of the same meaning (:mod:`hevlib.screen`):

    - always: exact test mass at most ``m_veh_max_kg`` (``m / m_max - 1``);
    - ``speed_dev_max``: the surrogate's predicted speed deviation (share of the sizing cycle off the
      trace) at most that (``pred / max - 1``), so fronts are not spent on designs that cannot follow
      the sizing cycle (a stalled design misses the trace for most of it);
    - ``stalled``: a callable ``X -> (n,) bool`` that says which designs stall (the simulator, where it
      is in the loop); a stalled design is infeasible (``+1``, else ``-1``) whatever its objectives;
    - ``gen_below_motor``: generator peak power below the motor's (``p_gen / p_mot - 1 < 0``, exact).

    ``buildable_gear_set`` makes the repair snap (n_r, n_s) to the nearest buildable planetary set.
    """

    def __init__(
        self,
        surrogate,
        space: DesignSpace,
        mass_kg: Callable[[np.ndarray], np.ndarray],
        m_veh_max_kg: float,
        *,
        speed_dev_max: float | None = None,
        gen_below_motor: bool = False,
        buildable_gear_set: bool = False,
        stalled: Callable[[np.ndarray], np.ndarray] | None = None,
    ):
        if not m_veh_max_kg > 0:
            raise ValueError(f"m_veh_max_kg: must be positive, got {m_veh_max_kg}")
        j_r, j_s = DESIGN_VARS.index("n_r"), DESIGN_VARS.index("n_s")
        if space.upper[j_s] >= space.lower[j_r]:
            raise ValueError(
                "design_space.n_s: upper bound must lie below n_r's lower bound, or the optimisers "
                "would propose gear sets with n_s >= n_r"
            )
        if speed_dev_max is not None and not speed_dev_max > 0:
            raise ValueError(f"speed_dev_max: must be positive, got {speed_dev_max}")
        self.constraint_names = (
            ["mass"]
            + (["speed_dev"] if speed_dev_max is not None else [])
            + (["gen_below_motor"] if gen_below_motor else [])
            + (["stalled"] if stalled is not None else [])
        )
        super().__init__(
            n_var=space.n,
            n_obj=len(OBJECTIVES),
            n_ieq_constr=len(self.constraint_names),
            xl=space.lower,
            xu=space.upper,
        )
        self.surrogate = surrogate
        self.mass_kg = mass_kg
        self.m_veh_max_kg = float(m_veh_max_kg)
        self.speed_dev_max = speed_dev_max
        self.stalled = stalled
        self.integer_mask = INTEGER_MASK.copy()
        self.n_not_evaluated = 0  # designs asked for that broke an exact rule (never predicted nor simulated)
        self.gear_sets = buildable_gear_sets(space) if buildable_gear_set else None
        if self.gear_sets is not None and len(self.gear_sets) == 0:
            raise ValueError("design_space: no buildable gear set (n_r, n_s) lies inside the bounds")

    def predict(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Predicted objectives (n, 11) in natural units and their standard deviation (None if unavailable)."""
        X = np.asarray(X, dtype=float)
        Y = self._checked(self.surrogate.predict(X), len(X), "predict")
        return Y, self._std(X)

    def _std(self, X: np.ndarray) -> np.ndarray | None:
        """``predict_std(X)``, or ``predict(X, return_std=True)[1]``, or None when the surrogate has neither."""
        if hasattr(self.surrogate, "predict_std"):
            return self._checked(self.surrogate.predict_std(X), len(X), "predict_std")
        if "return_std" in inspect.signature(self.surrogate.predict).parameters:
            return self._checked(self.surrogate.predict(X, return_std=True)[1], len(X), "predict_std")
        return None

    def constraint(self, X: np.ndarray, Y: np.ndarray | None = None) -> np.ndarray:
        """(n, n_ieq_constr) constraint values in ``constraint_names`` order; <= 0 is feasible. ``Y``: the
        predicted objectives of ``X`` when already known (the speed-deviation constraint reads them)."""
        X = np.asarray(X, dtype=float)
        exact = self.exact_constraint(X)
        cols = [exact[:, 0]]
        if self.speed_dev_max is not None:
            if Y is None:
                Y = self._checked(self.surrogate.predict(X), len(X), "predict")
            speed = {"speed_dev": Y[:, OBJECTIVES.index("speed_dev")]}
            cols.append(screen.speed_dev_max(self.speed_dev_max).constraint(speed))
        if "gen_below_motor" in self.constraint_names:
            cols.append(exact[:, 1])
        if self.stalled is not None:
            st = np.asarray(self.stalled(X), dtype=bool).reshape(-1)
            if st.shape != (len(X),):
                raise ValueError(f"stalled: expected {len(X)} flags, got shape {st.shape}")
            cols.append(screen.not_stalled().constraint({"stalled": st}))
        return np.column_stack(cols)

    #: The exact, cheap rules: known without a model, checked before any design is simulated or predicted.
    EXACT = ("mass", "gen_below_motor")

    def exact_constraint(self, X: np.ndarray) -> np.ndarray:
        """(n, k) values of the exact rules (``EXACT`` the problem has, in ``constraint_names`` order)."""
        X = np.asarray(X, dtype=float)
        m = np.asarray(self.mass_kg(X), dtype=float).reshape(-1)
        if m.shape != (len(X),) or not np.all(np.isfinite(m)):
            raise ValueError(f"mass_kg: expected {len(X)} finite masses, got shape {m.shape}")
        cols = [screen.mass_max(self.m_veh_max_kg).constraint({"m_veh": m})]
        if "gen_below_motor" in self.constraint_names:
            powers = {k: X[:, DESIGN_VARS.index(k)] for k in ("p_gen_kw", "p_mot_kw")}
            cols.append(screen.gen_below_motor().constraint(powers))
        return np.column_stack(cols)

    def admissible(self, X: np.ndarray) -> np.ndarray:
        """(n,) bool: designs that satisfy every exact rule -- the only ones any source may simulate."""
        return np.all(self.exact_constraint(X) <= 0.0, axis=1)

    def _evaluate(self, x, out, *args, **kwargs):
        """Objectives and constraints. On an expensive model (``model.expensive``: the simulator) a design
        that breaks an exact rule is not evaluated: its constraints are the exact rules' values (the
        model-based ones counted as met) and its objectives ``NOT_EVALUATED`` (every search compares an
        infeasible design by its violation alone). A surrogate predicts every design, as before: its
        searches simulate only their fronts, which meet the exact rules by construction."""
        x = np.asarray(x, dtype=float)
        if not getattr(self.surrogate, "expensive", False):
            Y = self._checked(self.surrogate.predict(x), len(x), "predict")
            out["F"] = to_minimisation(Y)
            out["G"] = self.constraint(x, Y)
            return
        exact = self.exact_constraint(x)
        ok = np.all(exact <= 0.0, axis=1)
        self.n_not_evaluated += int(np.count_nonzero(~ok))
        F = np.full((len(x), len(OBJECTIVES)), NOT_EVALUATED)
        G = np.zeros((len(x), self.n_ieq_constr))
        G[:, [self.constraint_names.index(k) for k in self.EXACT if k in self.constraint_names]] = exact
        if np.any(ok):
            Y = self._checked(self.surrogate.predict(x[ok]), int(np.count_nonzero(ok)), "predict")
            F[ok] = to_minimisation(Y)
            G[ok] = self.constraint(x[ok], Y)
        out["F"] = F
        out["G"] = G

    @staticmethod
    def _checked(Y, n: int, what: str) -> np.ndarray:
        Y = np.asarray(Y, dtype=float)
        if Y.shape != (n, len(OBJECTIVES)):
            raise ValueError(f"surrogate.{what}: expected shape ({n}, {len(OBJECTIVES)}), got {Y.shape}")
        if not np.all(np.isfinite(Y)):
            k = int(np.argmax(~np.all(np.isfinite(Y), axis=0)))
            raise ValueError(f"surrogate.{what}: {OBJECTIVES[k]} is not finite for some design")
        return Y


class IntegerRepair(Repair):
    """Round the integer columns (``mask``) to whole numbers within the bounds; other columns untouched.
    With ``gear_sets`` ((k, 2) buildable (n_r, n_s) pairs), snap the planetary set to the nearest one."""

    def __init__(self, mask, gear_sets: np.ndarray | None = None):
        super().__init__()
        self.mask = np.asarray(mask, dtype=bool)
        self.gear_sets = gear_sets

    def _do(self, problem, X, **kwargs):
        X = np.array(X, dtype=float)
        lo, hi = np.ceil(problem.xl[self.mask]), np.floor(problem.xu[self.mask])
        X[:, self.mask] = np.clip(np.round(X[:, self.mask]), lo, hi)
        if self.gear_sets is not None and len(X):
            j_r, j_s = DESIGN_VARS.index("n_r"), DESIGN_VARS.index("n_s")
            X[:, j_r], X[:, j_s] = nearest_gear_set(X[:, j_r], X[:, j_s], self.gear_sets)
        return X


def _integer_repair(problem: Problem) -> IntegerRepair | None:
    mask = getattr(problem, "integer_mask", None)
    if mask is None or not np.any(mask):
        return None
    return IntegerRepair(mask, getattr(problem, "gear_sets", None))


def _repaired(problem: Problem, X: np.ndarray) -> np.ndarray:
    repair = _integer_repair(problem)
    X = np.asarray(X, dtype=float)
    return repair._do(problem, X) if repair is not None else X


def sizing_problem(cfg, mass_kg: Callable, model, stalled=None) -> HevProblem:
    """The one sizing problem every source solves, on ``model``: the design space, the conventional car's
    test mass, and the screen's rules as constraints where ``optimise.apply_screen_rules`` (``cfg``: the
    validated params; ``mass_kg``: the simulator's test-mass model)."""
    rules = cfg.screen if cfg.optimise.apply_screen_rules else None
    return HevProblem(
        model,
        cfg.design_space.space(),
        mass_kg,
        cfg.baseline.conventional.test_mass_kg,
        speed_dev_max=rules.speed_dev_max if rules else None,
        gen_below_motor=bool(rules and rules.gen_below_motor),
        buildable_gear_set=bool(rules and rules.buildable_gear_set),
        stalled=stalled,
    )


def admissible_lhs(problem: HevProblem, space: DesignSpace, n: int, seed: int) -> np.ndarray:
    """``n`` designs of a seeded Latin hypercube (:func:`hevlib.doe.lhs_designs`), integers and gear sets
    repaired, that meet every exact rule: the first ``n`` admissible rows of the smallest hypercube of
    ``n * k`` designs that has them (designs that break a rule are never simulated, by any source)."""
    for k in range(1, 65):
        X = _repaired(problem, lhs_designs(space, n * k, seed))
        X = X[problem.admissible(X)]
        if len(X) >= n:
            return X[:n]
    raise ValueError(f"design_space: fewer than 1 in 64 designs meet the exact rules; cannot draw {n}")


def _evaluate_base(problem: Problem, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(F, G)`` of ``problem`` at ``X``; ``G`` is (n, 0) for an unconstrained problem."""
    if problem.n_ieq_constr == 0:
        return np.asarray(problem.evaluate(X, return_values_of=["F"]), dtype=float), np.zeros((len(X), 0))
    F, G = problem.evaluate(X, return_values_of=["F", "G"])
    return np.asarray(F, dtype=float), np.asarray(G, dtype=float).reshape(len(X), -1)


class _Reformulated(Problem):
    """A view of ``base`` for the weighted-sum GA: objectives normalised by ``norm`` and, with
    ``weights``, collapsed to a weighted sum; the base constraints pass through unchanged."""

    def __init__(self, base: Problem, norm: Normalisation, *, weights: np.ndarray | None = None):
        super().__init__(
            n_var=base.n_var,
            n_obj=base.n_obj if weights is None else 1,
            n_ieq_constr=base.n_ieq_constr,
            xl=base.xl,
            xu=base.xu,
        )
        self.base, self.norm = base, norm
        self.weights = None if weights is None else np.asarray(weights, dtype=float)
        self.integer_mask = getattr(base, "integer_mask", None)
        self.gear_sets = getattr(base, "gear_sets", None)

    def _evaluate(self, x, out, *args, **kwargs):
        F, G = _evaluate_base(self.base, x)
        F = self.norm(F)
        if self.weights is not None:
            F = F @ self.weights[:, None]
        if self.n_ieq_constr:
            out["G"] = G
        out["F"] = F


class RulesOnly:
    """A model that is never asked for objectives: for a problem used only for its rules and repair (the
    BoTorch sources, Latin-hypercube sampling, tabulating an archive's simulated objectives)."""

    def predict(self, X):  # pragma: no cover - never called
        raise AssertionError("this problem's model is never evaluated")


class SimulatorModel:
    """The simulator as the optimisers' model (the oracle): ``predict(X)`` simulates ``X`` on the sizing
    cycle and returns the eleven objectives; ``stalled(X)`` the stall flags of the same run.

    pymoo asks for objectives and constraints of one population in one call, so the last batch's
    responses are kept (keyed by the exact bytes of ``X``) and ``stalled`` of the same designs costs no
    second run. ``n_simulations`` counts every design simulated.
    """

    #: Every evaluation is a simulation: :class:`HevProblem` checks the exact rules first.
    expensive = True

    def __init__(self, simulate: Callable[[np.ndarray], pd.DataFrame]):
        self.simulate = simulate
        self.n_simulations = 0
        self._key: bytes | None = None
        self._last: pd.DataFrame | None = None

    def responses(self, X: np.ndarray) -> pd.DataFrame:
        X = np.ascontiguousarray(X, dtype=float)
        key = X.tobytes() + bytes(str(X.shape), "ascii")
        if key != self._key:
            self._last = self.simulate(X).reset_index(drop=True)
            self._key = key
            self.n_simulations += len(X)
        return self._last

    def predict(self, X: np.ndarray) -> np.ndarray:
        return self.responses(X)[list(OBJECTIVES)].to_numpy(dtype=float)

    def stalled(self, X: np.ndarray) -> np.ndarray:
        return self.responses(X)["stalled"].to_numpy(dtype=bool)
