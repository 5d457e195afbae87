"""The one place that builds and fits surrogates: :func:`fit_surrogate`, used by the ``surrogates`` stage
and by the infill loop of the optimisers (which refits after every round of simulations).

Imports neither torch nor the BNN module until a BNN is asked for.
"""

from __future__ import annotations

import numpy as np

from hevlib.design import DesignSpace
from hevlib.surrogates.base import Surrogate

KINDS = ("bnn", "regression")


def make_surrogate(kind: str, params, space: DesignSpace) -> Surrogate:
    """An unfitted surrogate ``kind`` (``bnn`` or ``regression``) configured by ``params``
    (``hevlib.params.SurrogateParams``: the ``surrogate`` block of params.yaml)."""
    if kind == "bnn":
        from hevlib.surrogates.bnn import BayesRegMLP

        return BayesRegMLP.from_params(space, params.bnn)
    if kind == "regression":
        from hevlib.surrogates.regression import LinearRegressions

        return LinearRegressions(space)
    raise ValueError(f"surrogate: unknown model {kind!r} (use {' or '.join(KINDS)})")


def fit_surrogate(kind: str, X: np.ndarray, Y: np.ndarray, params, space: DesignSpace) -> Surrogate:
    """Fit a surrogate ``kind`` (``bnn`` or ``regression``) on designs ``X`` (n, 7) and objectives ``Y``
    (n, 11, ``OBJECTIVES`` order, natural units), configured by ``params`` (``SurrogateParams``) over the
    design space ``space``. Returns the fitted model: ``predict(X) -> (n, 11)``, and for the BNN also
    ``predict(X, return_std=True) -> (mean, std)``. Every row given is used for fitting: the caller
    decides what the model may see (never held-out designs)."""
    return make_surrogate(kind, params, space).fit(X, Y)
