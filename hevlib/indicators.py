"""Quality indicators of objective fronts: normalisation, hypervolume (Monte Carlo and exact), IGD.

Every function takes objective matrices in minimisation form (``(n, m)``, all minimised; see
:func:`hevlib.pareto.to_minimisation`). Fronts of different algorithms are only comparable on a
common :class:`Normalisation` and a common reference point, so both are arguments, never derived
from the front being measured. The optimise stage takes the normalisation from every design simulated
before optimising (:meth:`Normalisation.from_points` over ``data/doe/doe.parquet`` and the held-out
Latin hypercube ``data/doe/heldout.parquet``): a function of the DOE, the held-out set and params only,
identical for the three algorithms.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Samples per Monte Carlo chunk times front size times objectives stays below this many booleans.
_MC_CHUNK_CELLS = 4_000_000


@dataclass(frozen=True)
class Normalisation:
    """Affine map of minimisation-form objectives onto [0, 1]: ``(F - ideal) / span``.

    ``span`` is ``nadir - ideal`` where that is positive and 1 (natural units) for an objective that is
    constant over the points the bounds came from, so the map is defined for every objective.
    """

    ideal: np.ndarray
    nadir: np.ndarray

    def __post_init__(self):
        ideal = np.asarray(self.ideal, dtype=float).ravel()
        nadir = np.asarray(self.nadir, dtype=float).ravel()
        if ideal.shape != nadir.shape:
            raise ValueError(f"normalisation: ideal has {ideal.size} objectives, nadir {nadir.size}")
        if not (np.all(np.isfinite(ideal)) and np.all(np.isfinite(nadir))):
            raise ValueError("normalisation: ideal and nadir must be finite")
        if np.any(nadir < ideal):
            raise ValueError(f"normalisation: nadir below ideal for objective {int(np.argmax(nadir < ideal))}")
        object.__setattr__(self, "ideal", ideal)
        object.__setattr__(self, "nadir", nadir)

    @classmethod
    def from_points(cls, F: np.ndarray) -> Normalisation:
        """Ideal and nadir as the column-wise min and max of the finite values of ``F`` (n, m)."""
        F = np.asarray(F, dtype=float)
        if F.ndim != 2 or F.shape[0] == 0:
            raise ValueError(f"normalisation: expected a non-empty (n, m) objective matrix, got {F.shape}")
        finite = np.isfinite(F)
        if not np.all(finite.any(axis=0)):
            raise ValueError(f"normalisation: objective {int(np.argmin(finite.any(axis=0)))} has no finite value")
        return cls(np.nanmin(np.where(finite, F, np.nan), axis=0), np.nanmax(np.where(finite, F, np.nan), axis=0))

    @property
    def span(self) -> np.ndarray:
        d = self.nadir - self.ideal
        return np.where(d > 0, d, 1.0)

    def __call__(self, F: np.ndarray) -> np.ndarray:
        F = np.asarray(F, dtype=float)
        if F.shape[-1] != self.ideal.size:
            raise ValueError(f"normalisation: expected {self.ideal.size} objectives, got {F.shape[-1]}")
        return (F - self.ideal) / self.span

    def to_dict(self) -> dict[str, list[float]]:
        return {"ideal": self.ideal.tolist(), "nadir": self.nadir.tolist()}


def _reference(reference, m: int) -> np.ndarray:
    r = np.broadcast_to(np.asarray(reference, dtype=float), (m,)).copy()
    if not np.all(np.isfinite(r)):
        raise ValueError("hypervolume: reference point must be finite")
    return r


def hypervolume_mc(F: np.ndarray, reference, *, n_samples: int, seed: int) -> tuple[float, float]:
    """Monte Carlo hypervolume of ``F`` (n, m; minimised) up to ``reference``: ``(estimate, standard error)``.

    Uniform points are drawn in the box ``[min(F), reference]`` (which holds the whole dominated region,
    so the estimate is unbiased whatever the front); the estimate is the box volume times the share of
    points some row of ``F`` weakly dominates, the standard error the binomial one of that share. Rows
    not strictly below the reference in every objective add nothing and are dropped first. Seeded:
    the same inputs give the same numbers.
    """
    F = np.asarray(F, dtype=float)
    if F.ndim != 2:
        raise ValueError(f"hypervolume: expected an (n, m) objective matrix, got shape {F.shape}")
    if n_samples < 1:
        raise ValueError("hypervolume: n_samples must be positive")
    r = _reference(reference, F.shape[1])
    F = F[np.all(np.isfinite(F), axis=1) & np.all(F < r, axis=1)]
    if len(F) == 0:
        return 0.0, 0.0
    lo = F.min(axis=0)
    volume = float(np.prod(r - lo))
    rng = np.random.default_rng(seed)
    chunk = max(1, _MC_CHUNK_CELLS // (F.shape[0] * F.shape[1]))
    hits = 0
    for start in range(0, n_samples, chunk):
        k = min(chunk, n_samples - start)
        Z = lo + rng.random((k, F.shape[1])) * (r - lo)
        hits += int(np.count_nonzero(np.any(np.all(F[None, :, :] <= Z[:, None, :], axis=2), axis=1)))
    p = hits / n_samples
    return volume * p, volume * float(np.sqrt(p * (1.0 - p) / n_samples))


def hypervolume_exact(F: np.ndarray, reference) -> float:
    """Exact hypervolume (pymoo / moocore); meant for 2-3 objectives (tests, small checks)."""
    from pymoo.indicators.hv import HV

    F = np.asarray(F, dtype=float)
    r = _reference(reference, F.shape[1])
    F = F[np.all(F < r, axis=1)]
    return float(HV(ref_point=r)(F)) if len(F) else 0.0


def igd(F: np.ndarray, reference_front: np.ndarray) -> float:
    """Inverted generational distance (pymoo): mean distance from each reference point to its nearest row of F."""
    from pymoo.indicators.igd import IGD

    F = np.asarray(F, dtype=float)
    R = np.asarray(reference_front, dtype=float)
    if F.ndim != 2 or R.ndim != 2 or F.shape[1] != R.shape[1] or len(F) == 0:
        raise ValueError(f"igd: front {F.shape} and reference front {R.shape} must be (n, m) with the same m")
    return float(IGD(R)(F))


__all__ = ["Normalisation", "hypervolume_mc", "hypervolume_exact", "igd"]
