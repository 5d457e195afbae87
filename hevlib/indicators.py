"""Quality indicators of objective fronts and the primitives they stand on: the minimisation form
(:func:`to_minimisation`), dominance (:func:`nondominated_mask`), normalisation, the hypervolume (exact, Monte
Carlo beyond a front size), IGD and IGD+, and ranking and thinning a set of designs (:func:`ideal_distance`,
:func:`rank_by`, :func:`pick_random`, :func:`pick_diverse`).

Every function takes objective matrices in minimisation form (``(n, m)``, all minimised; see
:func:`to_minimisation`). Fronts of different algorithms are only comparable on a
common :class:`Normalisation` and a common reference point, so both are arguments, never derived
from the front being measured. The optimise stage takes the normalisation from every design simulated
before optimising (:meth:`Normalisation.from_points` over ``data/doe/doe.parquet`` and the held-out
Latin hypercube ``data/doe/heldout.parquet``): a function of the DOE, the held-out set and params only,
identical for the three algorithms.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import moocore
import numpy as np
from numba import njit, prange

from hevlib.design import OBJECTIVES, SENSE

#: Monte Carlo samples drawn per chunk (the generator's stream does not depend on it).
_MC_CHUNK_SAMPLES = 65_536
_SENSE_OF = dict(zip(OBJECTIVES, SENSE, strict=True))


# ------------------------------------------------------------------ minimisation form, dominance
def nondominated_mask(F: np.ndarray, among: np.ndarray | None = None) -> np.ndarray:
    """Boolean mask of the rows of ``F`` (n, m; all minimised) that no other row dominates (moocore's
    ``is_nondominated``, in C: Kung, Luccio and Preparata's algorithm, O(n log n) for up to 3 objectives and
    O(n log^(m-2) n) beyond, the naive O(m n^2) loop for small n).

    A row with a non-finite objective (a run that failed) and, when ``among`` (n,) is given, a row outside it
    neither competes nor is ever non-dominated. Duplicated rows do not dominate each other, so all copies of a
    non-dominated point are kept.
    """
    F = np.asarray(F, dtype=float)
    if F.ndim != 2:
        raise ValueError(f"non-dominated filter: expected an (n, m) objective matrix, got shape {F.shape}")
    competes = np.all(np.isfinite(F), axis=1)
    if among is not None:
        competes &= np.asarray(among, dtype=bool)
    out = np.zeros(len(F), dtype=bool)
    if competes.any():
        out[competes] = np.asarray(moocore.is_nondominated(F[competes], keep_weakly=True), dtype=bool)
    return out


def sense_of(objectives: Sequence[str]) -> np.ndarray:
    """+1 (minimised) / -1 (maximised) per objective name; names outside OBJECTIVES are minimised."""
    return np.array([_SENSE_OF.get(k, 1.0) for k in objectives])


def to_minimisation(Y: np.ndarray, objectives: Sequence[str] = OBJECTIVES) -> np.ndarray:
    """Objectives (..., m) in natural units -> minimisation form (v_max, f_max negated); its own inverse.
    The one place maximised objectives change sign."""
    return np.asarray(Y, dtype=float) * sense_of(objectives)


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


def normalisation_dict(norm: Normalisation) -> dict:
    """``{ideal: {objective: value}, nadir: {...}}`` in each objective's own units (natural sense: for
    ``v_max``, ``f_max`` the ideal is the largest)."""
    ideal, nadir = to_minimisation(norm.ideal), to_minimisation(norm.nadir)
    return {
        "ideal": {k: float(v) for k, v in zip(OBJECTIVES, ideal, strict=True)},
        "nadir": {k: float(v) for k, v in zip(OBJECTIVES, nadir, strict=True)},
    }


def normalisation_from_dict(data: dict) -> Normalisation:
    """The inverse of :func:`normalisation_dict`."""
    ideal = to_minimisation(np.array([data["ideal"][k] for k in OBJECTIVES], dtype=float))
    nadir = to_minimisation(np.array([data["nadir"][k] for k in OBJECTIVES], dtype=float))
    return Normalisation(ideal, nadir)


def _reference(reference, m: int) -> np.ndarray:
    r = np.broadcast_to(np.asarray(reference, dtype=float), (m,)).copy()
    if not np.all(np.isfinite(r)):
        raise ValueError("hypervolume: reference point must be finite")
    return r


def _front(F: np.ndarray, reference) -> tuple[np.ndarray, np.ndarray]:
    """(the rows of ``F`` that add volume, the reference point): rows finite, strictly below the reference
    in every objective and non-dominated (dropping dominated rows changes neither the dominated region
    nor its bounding box)."""
    F = np.asarray(F, dtype=float)
    if F.ndim != 2:
        raise ValueError(f"hypervolume: expected an (n, m) objective matrix, got shape {F.shape}")
    r = _reference(reference, F.shape[1])
    F = F[np.all(np.isfinite(F), axis=1) & np.all(F < r, axis=1)]
    if len(F) < 2:
        return F, r
    return F[moocore.is_nondominated(F, keep_weakly=False)], r


@njit(parallel=True, cache=True)
def _count_dominated(by_obj: np.ndarray, sorted_vals: np.ndarray, Z: np.ndarray) -> int:  # pragma: no cover
    """How many rows of ``Z`` (k, m) some row of the front weakly dominates.

    ``by_obj[j]`` holds the front's rows sorted by objective ``j`` and ``sorted_vals[j]`` that objective's
    sorted values. A row can only dominate a sample ``z`` if it lies in the prefix of every ordering
    where ``F[:, j] <= z[j]``; each sample scans only the shortest of those prefixes (found by binary
    search), stopping at its first dominating row. Same count as checking every row, far fewer checks.
    """
    n_obj = Z.shape[1]
    hit = np.zeros(Z.shape[0], dtype=np.int64)
    for i in prange(Z.shape[0]):
        best_j, best_len = 0, by_obj.shape[1] + 1
        for j in range(n_obj):
            length = np.searchsorted(sorted_vals[j], Z[i, j], side="right")
            if length < best_len:
                best_j, best_len = j, length
        rows = by_obj[best_j]
        for p in range(best_len):
            dominated = True
            for j in range(n_obj):
                if rows[p, j] > Z[i, j]:
                    dominated = False
                    break
            if dominated:
                hit[i] = 1
                break
    return hit.sum()


def hypervolume_mc(F: np.ndarray, reference, *, n_samples: int, seed: int) -> tuple[float, float]:
    """Monte Carlo hypervolume of ``F`` (n, m; minimised) up to ``reference``: ``(estimate, standard error)``.

    Uniform points are drawn in the box ``[min(F), reference]`` (which holds the whole dominated region,
    so the estimate is unbiased whatever the front); the estimate is the box volume times the share of
    points some row of ``F`` weakly dominates, the standard error the binomial one of that share. Rows
    not strictly below the reference in every objective, and dominated rows, add nothing and are dropped
    first. Seeded: the same inputs give the same numbers (samples come from ``np.random.default_rng(seed)``
    in chunks, which draw the same stream as one call; counting is the numba loop of
    :func:`_count_dominated`).
    """
    return _mc(*_front(F, reference), n_samples, seed)


def _mc(F: np.ndarray, r: np.ndarray, n_samples: int, seed: int) -> tuple[float, float]:
    """:func:`hypervolume_mc` of rows already reduced by :func:`_front`."""
    if n_samples < 1:
        raise ValueError("hypervolume: n_samples must be positive")
    if len(F) == 0:
        return 0.0, 0.0
    lo = F.min(axis=0)
    volume = float(np.prod(r - lo))
    rng = np.random.default_rng(seed)
    chunk = _MC_CHUNK_SAMPLES
    by_obj, sorted_vals = _by_objective(F)
    hits = 0
    for start in range(0, n_samples, chunk):
        k = min(chunk, n_samples - start)
        hits += int(_count_dominated(by_obj, sorted_vals, lo + rng.random((k, F.shape[1])) * (r - lo)))
    return _estimate(volume, hits, n_samples)


def _by_objective(F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_count_dominated`'s view of a front: its rows sorted by each objective, and those values."""
    order = np.argsort(F, axis=0, kind="stable")  # (n, m): rows sorted by each objective
    by_obj = np.ascontiguousarray(np.stack([F[order[:, j]] for j in range(F.shape[1])]))
    return by_obj, np.ascontiguousarray(np.take_along_axis(F, order, axis=0).T)


def _estimate(volume: float, hits: int, n_samples: int) -> tuple[float, float]:
    """Box volume times the dominated share, and its binomial standard error."""
    p = hits / n_samples
    return volume * p, volume * float(np.sqrt(p * (1.0 - p) / n_samples))


def hypervolume_exact(F: np.ndarray, reference) -> float:
    """Exact hypervolume of ``F`` (n, m; minimised) up to ``reference`` (moocore, any m). Its cost grows
    steeply with the number of non-dominated rows at many objectives: see :func:`hypervolume`."""
    return _exact(*_front(F, reference))


def _exact(F: np.ndarray, r: np.ndarray) -> float:
    """:func:`hypervolume_exact` of rows already reduced by :func:`_front`."""
    return float(moocore.hypervolume(F, ref=r)) if len(F) else 0.0


@dataclass(frozen=True)
class Hypervolume:
    """A hypervolume and how it was computed: ``method`` is ``exact`` (moocore; ``se`` 0), ``monte_carlo``
    (seeded, ``n_samples`` samples, binomial standard error ``se``) or ``empty`` (no row below the
    reference). ``n_points``: the non-dominated rows below the reference (what the cost depends on);
    ``wall_s``: seconds it took (machine-dependent: kept out of the metrics)."""

    value: float
    se: float
    method: str
    n_points: int
    n_samples: int = 0
    wall_s: float = 0.0

    def describe(self) -> dict:
        """The deterministic part (what a report may hold): method, points, samples, value, error."""
        return {
            "method": self.method,
            "value": self.value,
            "se": self.se,
            "n_points": self.n_points,
            "n_samples": self.n_samples,
        }


def hypervolume(F: np.ndarray, reference, *, n_samples: int, seed: int, exact_max_points: int) -> Hypervolume:
    """The one hypervolume every report uses: of ``F`` (n, m; minimised) up to ``reference``, exact
    (:func:`hypervolume_exact`) when at most ``exact_max_points`` rows are non-dominated and below the
    reference, else the seeded Monte Carlo estimate (:func:`hypervolume_mc`) with ``n_samples`` samples
    as the documented fallback. The choice depends on the rows only, never on the clock, so a report
    has the same bytes on every machine.

    Cost of the exact one at 11 objectives, measured on the default pipeline's fronts (2 busy cores, moocore
    0.3.2): it depends on the front's shape as much as on its size. The weighted-sum GA's fronts are the
    worst: 50 rows 0.2 s, 60 rows 2 s, 70 rows 11-12 s, 80 rows 34-36 s, 101 rows 47 s; the oracle's 80
    rows take 1.6 s and NSGA-III's 104 rows 0.4 s. Hence ``params.optimise.hv_exact_max_points`` = 50. The
    Monte Carlo one costs about 0.5 s per 10^6 samples on a 200-row front (numba, 2 cores); its standard
    error is in the result."""
    t0 = time.perf_counter()
    F, r = _front(F, reference)  # once: the exact and Monte Carlo paths take the reduced rows as they are
    n = len(F)
    if n == 0:
        return Hypervolume(0.0, 0.0, "empty", 0, 0, time.perf_counter() - t0)
    if n <= exact_max_points:
        return Hypervolume(_exact(F, r), 0.0, "exact", n, 0, time.perf_counter() - t0)
    value, se = _mc(F, r, n_samples, seed)
    return Hypervolume(value, se, "monte_carlo", n, int(n_samples), time.perf_counter() - t0)


@dataclass(frozen=True)
class CommonSamples:
    """Monte Carlo hypervolume with one set of uniform samples for every front it measures (common random
    numbers: the difference between two fronts' estimates has far less noise than either estimate).

    The samples fill the box ``[lower, reference]``, which must hold every point of every front measured
    (:meth:`of` raises otherwise); ``lower`` is fixed before measuring (e.g. the minimum over every front
    to be compared). Estimate: box volume times the share of samples some row weakly dominates; the
    standard error is the binomial one."""

    lower: np.ndarray
    reference: np.ndarray
    samples: np.ndarray  # (n, m) in the box

    @classmethod
    def draw(cls, lower, reference, n_samples: int, seed: int) -> CommonSamples:
        lo = np.asarray(lower, dtype=float).ravel()
        r = _reference(reference, lo.size)
        if np.any(lo >= r):
            raise ValueError("hypervolume samples: lower corner must lie below the reference in every objective")
        rng = np.random.default_rng(seed)
        Z = lo + rng.random((int(n_samples), lo.size)) * (r - lo)
        return cls(lo, r, Z)

    @property
    def volume(self) -> float:
        return float(np.prod(self.reference - self.lower))

    def of(self, F: np.ndarray) -> tuple[float, float]:
        """(hypervolume, standard error) of ``F`` (n, m; minimised, normalised like the box)."""
        F, r = _front(F, self.reference)
        if len(F) == 0:
            return 0.0, 0.0
        if np.any(F < self.lower):
            raise ValueError("hypervolume samples: a front reaches below the samples' box")
        by_obj, sorted_vals = _by_objective(F)
        n, chunk = len(self.samples), _MC_CHUNK_SAMPLES * 8
        hits = sum(int(_count_dominated(by_obj, sorted_vals, self.samples[i : i + chunk])) for i in range(0, n, chunk))
        return _estimate(self.volume, hits, n)


@njit(parallel=True, cache=True)
def _igd_plus(A: np.ndarray, R: np.ndarray) -> float:  # pragma: no cover
    total = np.zeros(R.shape[0])
    for i in prange(R.shape[0]):
        best = np.inf
        for a in range(A.shape[0]):
            d = 0.0
            for j in range(R.shape[1]):
                e = A[a, j] - R[i, j]
                if e > 0.0:
                    d += e * e
                    if d >= best:
                        break
            if d < best:
                best = d
        total[i] = np.sqrt(best)
    return total.mean()


def igd_plus(F: np.ndarray, reference_front: np.ndarray) -> float:
    """IGD+ (Ishibuchi et al. 2015): mean over the reference front's points ``r`` of the distance to the
    nearest row ``a`` of ``F`` counting only where ``a`` is worse, ``sqrt(sum_j max(a_j - r_j, 0)^2)``;
    weakly Pareto-compliant, 0 when ``F`` covers the reference front. Both minimised, same scaling."""
    F = np.ascontiguousarray(np.asarray(F, dtype=float))
    R = np.ascontiguousarray(np.asarray(reference_front, dtype=float))
    if F.ndim != 2 or R.ndim != 2 or F.shape[1] != R.shape[1] or len(R) == 0:
        raise ValueError(f"igd+: front {F.shape} and reference front {R.shape} must be (n, m) with the same m")
    if len(F) == 0:
        return float("inf")
    return float(_igd_plus(F, R))


@njit(parallel=True, cache=True)
def _dominated_samples(F, Z, first, start, out) -> np.ndarray:  # pragma: no cover
    """How many samples (rows of ``Z``) each row of ``F`` weakly dominates, looking at row ``i``'s samples from
    ``first[i]`` on (``Z`` sorted on one objective: the samples before ``first[i]`` are below row ``i`` in it);
    with ``out`` non-empty, also their indices, row ``i``'s from ``out[start[i]]`` on (the counts of a first
    pass give ``start``)."""
    counts = np.zeros(F.shape[0], dtype=np.int64)
    write = out.size > 0
    for i in prange(F.shape[0]):
        c = 0
        for s in range(first[i], Z.shape[0]):
            ok = True
            for j in range(F.shape[1]):
                if F[i, j] > Z[s, j]:
                    ok = False
                    break
            if ok:
                if write:
                    out[start[i] + c] = s
                c += 1
        counts[i] = c
    return counts


def _sorted_samples(F: np.ndarray, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``Z``'s rows sorted on the objective that rules out the most (row, sample) pairs of ``F`` at once (a
    sample below a row in any objective is not dominated by it), and per row of ``F`` the first sorted sample
    not below it there: :func:`_dominated_samples` scans only from there, and counts the same samples."""
    firsts = np.stack([np.searchsorted(np.sort(Z[:, j]), F[:, j], side="left") for j in range(F.shape[1])])
    c = int(np.argmax(firsts.sum(axis=1)))
    return np.ascontiguousarray(Z[np.argsort(Z[:, c], kind="stable")]), firsts[c].astype(np.int64)


@njit(cache=True)
def _greedy_cover(start: np.ndarray, items: np.ndarray, n_samples: int, k: int) -> np.ndarray:  # pragma: no cover
    """Greedy maximum coverage: ``k`` sets (CSR ``start``/``items``) each adding the most uncovered samples
    (ties: the lower index); stops early when no set adds any."""
    n = start.size - 1
    covered = np.zeros(n_samples, dtype=np.bool_)
    taken = np.zeros(n, dtype=np.bool_)
    gain = np.empty(n, dtype=np.int64)
    for i in range(n):
        gain[i] = start[i + 1] - start[i]  # an upper bound on the true gain from now on (lazy greedy)
    chosen = np.full(k, -1, dtype=np.int64)
    for t in range(k):
        while True:
            best, best_i = -1, -1
            for i in range(n):
                if not taken[i] and gain[i] > best:
                    best, best_i = gain[i], i
            if best_i < 0 or best <= 0:
                return chosen[:t]
            g = 0
            for p in range(start[best_i], start[best_i + 1]):
                if not covered[items[p]]:
                    g += 1
            gain[best_i] = g
            second = -1
            for i in range(n):
                if not taken[i] and i != best_i and gain[i] > second:
                    second = gain[i]
            if g >= second and g > 0:
                break
            if g <= 0 and second <= 0:
                return chosen[:t]
        taken[best_i] = True
        chosen[t] = best_i
        for p in range(start[best_i], start[best_i + 1]):
            covered[items[p]] = True
    return chosen


def hv_greedy_subset(F: np.ndarray, k: int, reference, *, n_samples: int, seed: int) -> np.ndarray:
    """Indices (sorted) of ``k`` rows of ``F`` (n, m; minimised, normalised) chosen greedily for
    hypervolume: each next row is the one whose dominated region adds the most to the rows already
    chosen (Monte Carlo: ``n_samples`` seeded uniform samples in ``[min(F), reference]``; lazy greedy on
    the samples each row dominates, which is the greedy of a submodular function: within ``1 - 1/e`` of the
    best ``k``-subset's estimate). Rows that add nothing (outside the reference box, or covered by the
    chosen ones) come last, in order of the samples they dominate alone, then of index. All rows when
    ``n <= k``."""
    F = np.asarray(F, dtype=float)
    n = len(F)
    if n <= k:
        return np.arange(n)
    r = _reference(reference, F.shape[1])
    usable = np.flatnonzero(np.all(np.isfinite(F), axis=1) & np.all(F < r, axis=1))
    chosen = np.zeros(0, dtype=np.int64)
    alone = np.zeros(n, dtype=np.int64)
    if len(usable):
        Fu = np.ascontiguousarray(F[usable])
        lo = Fu.min(axis=0)
        Z = lo + np.random.default_rng(seed).random((int(n_samples), F.shape[1])) * (r - lo)
        Z, first = _sorted_samples(Fu, Z)  # the greedy needs which samples a row covers, not their order
        counts = _dominated_samples(Fu, Z, first, np.zeros(len(Fu) + 1, dtype=np.int64), np.empty(0, dtype=np.int64))
        start = np.zeros(len(Fu) + 1, dtype=np.int64)
        start[1:] = np.cumsum(counts)
        items = np.empty(int(start[-1]), dtype=np.int64)
        _dominated_samples(Fu, Z, first, start, items)
        chosen = usable[_greedy_cover(start, items, int(n_samples), int(k))]
        alone[usable] = counts
    if len(chosen) < k:
        rest = np.setdiff1d(np.arange(n), chosen)
        order = np.lexsort((rest, -alone[rest]))
        chosen = np.concatenate([chosen, rest[order][: k - len(chosen)]])
    return np.sort(chosen)


def igd(F: np.ndarray, reference_front: np.ndarray) -> float:
    """Inverted generational distance (pymoo): mean distance from each reference point to its nearest row of F."""
    from pymoo.indicators.igd import IGD

    F = np.asarray(F, dtype=float)
    R = np.asarray(reference_front, dtype=float)
    if F.ndim != 2 or R.ndim != 2 or F.shape[1] != R.shape[1] or len(F) == 0:
        raise ValueError(f"igd: front {F.shape} and reference front {R.shape} must be (n, m) with the same m")
    return float(IGD(R)(F))


# ------------------------------------------------------------------------------ rank and thin
def normalise(F: np.ndarray, ref: np.ndarray | None = None) -> np.ndarray:
    """Min-max normalise the columns of ``F`` over the rows of ``ref`` (default ``F``) with the one
    :class:`Normalisation`; an objective constant over ``ref`` carries no preference
    in a ranking, so it maps to 0 here."""
    F = np.asarray(F, dtype=float)
    ref = F if ref is None else np.asarray(ref, dtype=float)
    if len(ref) == 0:
        return np.zeros_like(F)
    norm = Normalisation(ref.min(axis=0), ref.max(axis=0))
    return np.where(norm.nadir > norm.ideal, norm(F), 0.0)


def ideal_distance(F: np.ndarray) -> np.ndarray:
    """Euclidean distance of each row of ``F`` (minimisation form) to the ideal point, after normalising."""
    return np.linalg.norm(normalise(F), axis=1)


def rank_by(distance: np.ndarray) -> np.ndarray:
    """1-based ranks, smallest distance first; ties keep the input order."""
    order = np.argsort(distance, kind="stable")
    rank = np.empty(len(distance), dtype=np.int64)
    rank[order] = np.arange(1, len(distance) + 1)
    return rank


def pick_random(n: int, k: int, seed: int) -> np.ndarray:
    """``min(k, n)`` distinct indices of ``range(n)``, drawn with ``np.random.default_rng(seed)``, sorted."""
    rng = np.random.default_rng(seed)
    return np.sort(rng.choice(n, size=min(k, n), replace=False))


def pick_diverse(F_norm: np.ndarray, k: int, start: int | Sequence[int] = 0) -> np.ndarray:
    """Farthest-point sampling: from ``start`` (one row, or seed rows taken first, in order, once each),
    repeatedly add the row farthest from those picked.

    Deterministic (ties go to the lowest index); returns ``min(k, n)`` indices in the order picked.
    """
    F_norm = np.asarray(F_norm, dtype=float)
    n = len(F_norm)
    k = min(k, n)
    seeds = [start] if np.ndim(start) == 0 else list(start)
    picked = list(dict.fromkeys(int(s) for s in seeds))[:k]
    if not picked:
        return np.zeros(0, dtype=np.int64)
    dmin = np.linalg.norm(F_norm - F_norm[picked[0]], axis=1)
    for s in picked[1:]:
        dmin = np.minimum(dmin, np.linalg.norm(F_norm - F_norm[s], axis=1))
    while len(picked) < k:
        dmin[picked] = -np.inf
        nxt = int(np.argmax(dmin))
        picked.append(nxt)
        dmin = np.minimum(dmin, np.linalg.norm(F_norm - F_norm[nxt], axis=1))
    return np.array(picked, dtype=np.int64)


__all__ = [
    "CommonSamples",
    "Hypervolume",
    "Normalisation",
    "hypervolume",
    "hypervolume_exact",
    "hypervolume_mc",
    "hv_greedy_subset",
    "ideal_distance",
    "igd",
    "igd_plus",
    "nondominated_mask",
    "normalisation_dict",
    "normalisation_from_dict",
    "normalise",
    "pick_diverse",
    "pick_random",
    "rank_by",
    "sense_of",
    "to_minimisation",
]
