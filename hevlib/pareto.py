"""Pareto dominance on objective matrices in minimisation form."""

from __future__ import annotations

import numpy as np


def nondominated_mask(F: np.ndarray) -> np.ndarray:
    """Boolean mask of the rows of ``F`` (n, m; all minimised) that no other row dominates.

    Duplicated rows do not dominate each other, so all copies of a non-dominated point are kept.
    """
    F = np.asarray(F, dtype=float)
    n = F.shape[0]
    keep = np.ones(n, dtype=bool)
    for start in range(0, n, 512):  # blocks keep memory at O(512 * n * m)
        block = F[start:start + 512]
        le = np.all(F[None, :, :] <= block[:, None, :], axis=2)
        lt = np.any(F[None, :, :] < block[:, None, :], axis=2)
        keep[start:start + 512] = ~np.any(le & lt, axis=1)
    return keep
