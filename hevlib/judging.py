"""How every source is judged: one objective matrix, one screen, one normalisation, one hypervolume.

The optimise stage reports each source's fronts and archive with :class:`HvSettings`, the pareto stage
compares the sources with it (:func:`hevlib.pareto.source_summary`) and the benchmark scores its runs on the
same terms:

- :func:`objective_matrix` -- a table's ``sim_`` objectives as an (n, m) matrix in minimisation form;
- :func:`judged_normalisation` -- ideal and nadir of the screen-passing designs of the judged scale's reference
  set (``hev judge``), :func:`screened_normalisation` of any simulated tables;
- :class:`HvSettings` -- the hypervolume of a front's screen-passing designs on that normalisation
  (:func:`screened_hypervolume`, by :func:`hevlib.indicators.hypervolume`), and :func:`spread`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from hevlib.design import OBJECTIVES, RESPONSES
from hevlib.indicators import Hypervolume, Normalisation, hypervolume, normalisation_dict, to_minimisation
from hevlib.params import OptimiseParams
from hevlib.screen import SIM, passes_screen
from hevlib.tables import Table, columns, matrix, n_rows


def objective_matrix(
    table: Table, objectives: Sequence[str] = OBJECTIVES, *, prefix: str = SIM, what: str = "designs"
) -> np.ndarray:
    """The (n, m) matrix of ``<prefix><objective>`` columns in minimisation form (maximised ones negated);
    only those columns of a lazy table are read (null -> NaN)."""
    cols = [f"{prefix}{k}" for k in objectives]
    have = set(columns(table))
    missing = [c for c in cols if c not in have]
    if missing:
        raise ValueError(f"{what}: missing objective column(s) {', '.join(missing)}")
    return to_minimisation(matrix(table, cols), objectives)


def simulated_as_front(table: Table) -> Table:
    """A table of simulated designs (DOE, held-out: unprefixed responses) with the ``sim_`` names a front
    uses; the same kind of table back (a polars one lazily renamed, nothing read)."""
    names = {k: f"{SIM}{k}" for k in RESPONSES if k in columns(table)}
    return table.rename(columns=names) if isinstance(table, pd.DataFrame) else table.rename(names)


def screened_normalisation(tables: Sequence[Table], screen) -> Normalisation:
    """The hypervolume's normalisation: ideal and nadir (minimisation form) of the simulated designs of
    ``tables`` (``sim_`` columns) that pass the screen, so every objective spans the range of designs a
    user could pick (not of designs that barely move, which would squeeze fuel and emissions into a
    sliver near 0). Raises if no design passes."""
    F = []
    for t in tables:
        Ft = objective_matrix(t, OBJECTIVES, what="table")
        F.append(Ft[passes_screen(t, screen) & np.all(np.isfinite(Ft), axis=1)])
    F = np.vstack(F) if F else np.zeros((0, len(OBJECTIVES)))
    if len(F) == 0:
        raise ValueError("hypervolume normalisation: no simulated design passes the screen")
    return Normalisation.from_points(F)


#: What :func:`judged_normalisation` is built from, as the reports say it (``normalisation.built_from``).
JUDGED_SCALE = (
    "screen-passing designs of data/judge/reference.parquet, the judged scale (`hev judge`: a Latin hypercube of "
    "admissible designs no source produced; never given to a search)"
)


def judged_normalisation(reference: Table, screen) -> Normalisation:
    """The normalisation every source is judged on: :func:`screened_normalisation` of the judged scale's
    reference set (``hev judge``: a large Latin hypercube of admissible designs, unprefixed responses as
    simulated) -- data no source produced. It scores; no search ever sees it."""
    return screened_normalisation([simulated_as_front(reference)], screen)


def screened_hypervolume(
    table: Table,
    screen,
    norm: Normalisation,
    reference: float,
    n_samples: int,
    seed: int,
    exact_max_points: int,
) -> tuple[Hypervolume, int]:
    """(hypervolume, designs counted) of the screen-passing rows of a front (``sim_`` objectives; every row
    with finite objectives when ``screen`` is None) on ``norm``, by :func:`hevlib.indicators.hypervolume`."""
    if n_rows(table) == 0:
        return hypervolume(
            np.zeros((0, len(OBJECTIVES))), reference, n_samples=n_samples, seed=seed, exact_max_points=exact_max_points
        ), 0
    F = objective_matrix(table, OBJECTIVES, what="front")
    ok = np.all(np.isfinite(F), axis=1)
    if screen is not None:
        ok &= passes_screen(table, screen)
    hv = hypervolume(norm(F[ok]), reference, n_samples=n_samples, seed=seed, exact_max_points=exact_max_points)
    return hv, int(ok.sum())


@dataclass(frozen=True)
class HvSettings:
    """The one hypervolume of every source: simulated objectives of the designs that pass ``screen``
    (``params.screen``; all designs when None), normalised by ``norm`` (ideal and nadir of screen-passing
    simulated designs, :func:`screened_normalisation`), up to ``reference`` in every normalised objective;
    exact up to ``exact_max_points`` non-dominated designs, else Monte Carlo with ``n_samples`` samples
    seeded by ``seed`` (:func:`hevlib.indicators.hypervolume`)."""

    norm: Normalisation
    reference: float = OptimiseParams.model_fields["hv_reference"].default
    n_samples: int = OptimiseParams.model_fields["hv_samples"].default
    seed: int = OptimiseParams.model_fields["hv_seed"].default
    screen: object | None = None  # params.screen; None counts every design with finite objectives
    exact_max_points: int = OptimiseParams.model_fields["hv_exact_max_points"].default

    @classmethod
    def from_params(cls, norm: Normalisation, optimise, screen) -> HvSettings:
        """The settings of ``params.optimise`` (``hv_*``) on ``norm``, screening by ``params.screen``."""
        return cls(
            norm, optimise.hv_reference, optimise.hv_samples, optimise.hv_seed, screen, optimise.hv_exact_max_points
        )

    def of(self, table: Table) -> tuple[Hypervolume, int]:
        """(hypervolume, designs counted) of a front table (``sim_`` columns)."""
        return screened_hypervolume(
            table, self.screen, self.norm, self.reference, self.n_samples, self.seed, self.exact_max_points
        )

    def describe(self) -> dict:
        return {
            "space": "simulated objectives of screen-passing designs, minimisation form, (F - ideal) / (nadir - ideal)",
            "function": "hevlib.indicators.hypervolume",
            "reference": self.reference,
            "exact_max_points": self.exact_max_points,
            "exact": "moocore.hypervolume, when at most exact_max_points non-dominated designs lie below the reference",
            "fallback": "Monte Carlo: n_samples seeded uniform samples in [min(F), reference], binomial standard error",
            "n_samples": self.n_samples,
            "seed": self.seed,
            "normalisation": normalisation_dict(self.norm),
        }


def spread(table: Table, norm: Normalisation) -> dict[str, float]:
    """Per objective, the range of a front's simulated values in normalised units (0 = collapsed)."""
    F = norm(objective_matrix(table, OBJECTIVES, what="front"))
    F = F[np.all(np.isfinite(F), axis=1)]
    return {k: (float(np.ptp(F[:, j])) if len(F) else 0.0) for j, k in enumerate(OBJECTIVES)}


__all__ = [
    "HvSettings",
    "judged_normalisation",
    "objective_matrix",
    "screened_hypervolume",
    "screened_normalisation",
    "simulated_as_front",
    "spread",
]
