"""The one interface every surrogate offers the optimisers (scikit-learn style fit / predict).

Also the input checks both surrogates share, so every model rejects bad designs with the same message.
"""

from __future__ import annotations

from typing import Protocol, Self, runtime_checkable

import numpy as np

from hevlib.design import OBJECTIVES, DesignSpace


@runtime_checkable
class Surrogate(Protocol):
    """Predicts the eleven objectives (``hevlib.design.OBJECTIVES`` order, natural units) of designs.

    ``X`` is (n, 7) in ``DESIGN_VARS`` order; integer variables may be given as reals (continuous
    relaxation). Designs outside the design space raise ``ValueError`` naming the variable. A surrogate
    that reports uncertainty (the BNN) also accepts ``predict(X, return_std=True) -> (mean, std)``.
    """

    def fit(self, X: np.ndarray, Y: np.ndarray) -> Self: ...

    def predict(self, X: np.ndarray) -> np.ndarray: ...


#: Physical range of every objective (``OBJECTIVES`` order): every one but ``diff_soc`` is non-negative,
#: ``speed_dev`` is a share of the cycle (0-1), ``accel_dev`` a percentage (0-100), ``diff_soc`` a difference
#: of two states of charge (-1..1). Both surrogates clip their predictions to it (:func:`clip_objectives`).
OBJECTIVE_BOUNDS: dict[str, tuple[float, float]] = {
    **{name: (0.0, np.inf) for name in OBJECTIVES},
    "accel_dev": (0.0, 100.0),
    "speed_dev": (0.0, 1.0),
    "diff_soc": (-1.0, 1.0),
}
_LOWER = np.array([OBJECTIVE_BOUNDS[name][0] for name in OBJECTIVES])
_UPPER = np.array([OBJECTIVE_BOUNDS[name][1] for name in OBJECTIVES])


def clip_objectives(Y: np.ndarray) -> np.ndarray:
    """Predictions (n, 11) clipped to :data:`OBJECTIVE_BOUNDS` (so a surrogate never predicts a negative
    fuel consumption, mass, emission, distance or deviation, nor a speed deviation above 1)."""
    return np.clip(Y, _LOWER, _UPPER)


class NotFittedError(ValueError):
    """``predict`` or ``save`` called on a surrogate that has not been fitted or loaded."""


def check_designs(space: DesignSpace, X: np.ndarray, *, what: str = "surrogate input") -> np.ndarray:
    """``X`` as a float (n, 7) array inside ``space`` (integers relaxed); ValueError naming the variable."""
    X = space.check(X, what=what, integers=False)
    if X.shape[0] == 0:
        raise ValueError(f"{what}: no designs (0 rows)")
    return X


def check_targets(Y: np.ndarray, n: int, *, what: str = "surrogate targets") -> np.ndarray:
    """``Y`` as a finite float (n, 11) array in ``OBJECTIVES`` order; ValueError naming the objective."""
    Y = np.asarray(Y, dtype=float)
    if Y.ndim != 2 or Y.shape != (n, len(OBJECTIVES)):
        raise ValueError(f"{what}: expected shape ({n}, {len(OBJECTIVES)}) in order {OBJECTIVES}, got {Y.shape}")
    for k, name in enumerate(OBJECTIVES):
        bad = ~np.isfinite(Y[:, k])
        if np.any(bad):
            raise ValueError(f"{what}: {name} is not finite (NaN or inf) in row {int(np.argmax(bad)) + 1}")
    return Y


def space_to_dict(space: DesignSpace) -> dict[str, list[float]]:
    """The design-space bounds as plain lists (stored with every saved model)."""
    return {"lower": [float(v) for v in space.lower], "upper": [float(v) for v in space.upper]}


def space_from_dict(data: dict) -> DesignSpace:
    return DesignSpace(np.asarray(data["lower"], dtype=float), np.asarray(data["upper"], dtype=float))
