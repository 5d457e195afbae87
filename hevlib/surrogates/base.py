"""The one interface every surrogate offers the optimisers (scikit-learn style fit / predict)."""

from __future__ import annotations

from typing import Protocol, Self, runtime_checkable

import numpy as np


@runtime_checkable
class Surrogate(Protocol):
    """Predicts the eleven objectives (``hevlib.design.OBJECTIVES`` order, natural units) of designs.

    ``X`` is (n, 7) in ``DESIGN_VARS`` order; integer variables may be given as reals (continuous
    relaxation). Designs outside the design space raise ``ValueError`` naming the variable.
    """

    def fit(self, X: np.ndarray, Y: np.ndarray) -> Self: ...

    def predict(self, X: np.ndarray) -> np.ndarray: ...
