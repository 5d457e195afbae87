"""Surrogates of the simulator: Bayesian-regularised MLPs (``bnn``) and linear regressions.

Both follow :class:`hevlib.surrogates.base.Surrogate`; fit one with :func:`fit_surrogate` (the only place
models are built) and load a saved one with :func:`load_surrogate`. Importing this package does not
import torch (only saving or loading a BNN does).
"""

from hevlib.surrogates.base import OBJECTIVE_BOUNDS, Surrogate, clip_objectives
from hevlib.surrogates.fitting import fit_surrogate, make_surrogate
from hevlib.surrogates.metrics import load_surrogate

__all__ = ["OBJECTIVE_BOUNDS", "Surrogate", "clip_objectives", "fit_surrogate", "load_surrogate", "make_surrogate"]
