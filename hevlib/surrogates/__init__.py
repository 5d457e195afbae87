"""Surrogates of the simulator: a Bayesian-regularised MLP (``bnn``) and linear regressions.

Both follow :class:`hevlib.surrogates.base.Surrogate`; load a fitted one with
:func:`hevlib.surrogates.metrics.load_surrogate`. Importing this package does not import torch.
"""

from hevlib.surrogates.base import Surrogate
from hevlib.surrogates.metrics import load_surrogate

__all__ = ["Surrogate", "load_surrogate"]
