"""MOEA/D with bounded replacement (Li & Zhang 2009, MOEA/D-DE's diversity rules): :class:`MOEADBounded`,
a pymoo ``Algorithm`` in numpy, driven by ``pymoo.optimize.minimize`` as every optimiser here is.

Why not pymoo's ``MOEAD``: its replacement puts an offspring into *every* neighbour whose subproblem it
improves (no bound), mating and replacement always use the neighbourhood, and it takes no constraints
(so they had to be a penalty). In 11 objectives one good offspring then overwrites up to ``T`` slots in
one step, its copies mate with each other, and the population contracts to one cluster: on the sizing
problem all 131 designs of the old front sat in one cluster, ``p_gen`` at its lower bound.

This one

- makes one offspring per subproblem per generation and evaluates the whole batch in one call of
  ``problem.evaluate`` (the surrogate is called once per generation);
- takes the mating pool of subproblem ``i`` from its ``T`` nearest directions with probability
  ``delta``, else from the whole population; the same pool is the replacement pool;
- lets an offspring replace at most ``n_replace`` members of that pool (visited in random order), so a
  single offspring never takes over a neighbourhood;
- compares by constraint domination (feasible beats infeasible, two infeasible by violation, two
  feasible by the aggregation), so constraints need no penalty weight;
- normalises objectives online: ideal = best feasible value seen so far, nadir = worst value of the
  current feasible population;
- aggregates with Tchebycheff (``max_j w_j |f_j - z_j|``, the default) or PBI (``d1 + theta d2``).

Tchebycheff, not PBI: with 7 variables the reachable front of 11 objectives is at most 6-dimensional,
so most of the 200 directions miss it; PBI's penalty on the distance from the direction then hands
every such subproblem to the same few designs and the population collapses (measured on the sizing
problem at 200 x 200: PBI 1 cluster with online normalisation, 42 with a fixed one, hypervolume 0.3-0.4
of NSGA-III's; Tchebycheff 113 clusters and 1.3 times NSGA-III's; at 200 x 500, 0.9 times, against 0.22
for pymoo's MOEA/D). Bounded replacement and constraint domination each add a little on top.

Variation: SBX (crossover probability per mating, 0.5 per variable) and polynomial mutation, Deb's
operators as pymoo applies them, then the problem's repair. Deterministic for a given seed.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from pymoo.core.algorithm import Algorithm
from pymoo.core.population import Population

from hevlib.optimise.problem import NOT_EVALUATED

DECOMPOSITIONS = ("tchebycheff", "pbi")


# ---------------------------------------------------------------------------- aggregation
def aggregate(Fn: np.ndarray, W: np.ndarray, kind: str, theta: float = 5.0) -> np.ndarray:
    """Row-wise aggregation ``g(Fn[k] | W[k])`` of objectives already shifted by the ideal point
    (``Fn = (F - z) / span``; all rows >= ~0). ``Fn`` and ``W`` are (k, m); returns (k,)."""
    if kind == "tchebycheff":
        return np.max(np.maximum(W, 1e-6) * np.abs(Fn), axis=1)
    if kind == "pbi":
        u = W / np.linalg.norm(W, axis=1, keepdims=True)
        d1 = np.sum(Fn * u, axis=1)
        d2 = np.linalg.norm(Fn - d1[:, None] * u, axis=1)
        return d1 + theta * d2
    raise ValueError(f"decomposition: unknown {kind!r} (use one of {', '.join(DECOMPOSITIONS)})")


# ------------------------------------------------------------------------------ variation
def sbx(rng, X1, X2, xl, xu, *, prob, eta=15.0, prob_var=0.5):
    """Simulated binary crossover (Deb & Agrawal 1995, bounded form as in pymoo/NSGA-II's C code) of
    parent rows ``X1``, ``X2`` (k, n); returns ONE child per pair (the first or second, at random).
    Each pair is crossed with probability ``prob``, each variable with ``prob_var``."""
    k, n = X1.shape
    c1, c2 = X1.copy(), X2.copy()
    do = (rng.random((k, 1)) < prob) & (rng.random((k, n)) < prob_var) & (np.abs(X1 - X2) > 1e-14)
    y1, y2 = np.minimum(X1, X2), np.maximum(X1, X2)
    dy = np.where(do, y2 - y1, 1.0)
    rand = rng.random((k, n))

    def betaq(beta):
        alpha = 2.0 - np.power(beta, -(eta + 1.0))
        mask = rand <= 1.0 / alpha
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            a = np.power(rand * alpha, 1.0 / (eta + 1.0))
            b = np.power(1.0 / np.maximum(2.0 - rand * alpha, 1e-300), 1.0 / (eta + 1.0))
        return np.where(mask, a, b)

    beta = 1.0 + 2.0 * (y1 - xl) / dy
    ch1 = 0.5 * (y1 + y2 - betaq(beta) * (y2 - y1))
    beta = 1.0 + 2.0 * (xu - y2) / dy
    ch2 = 0.5 * (y1 + y2 + betaq(beta) * (y2 - y1))
    ch1, ch2 = np.clip(ch1, xl, xu), np.clip(ch2, xl, xu)
    swap = rng.random((k, n)) < 0.5
    ch1, ch2 = np.where(swap, ch2, ch1), np.where(swap, ch1, ch2)
    c1 = np.where(do, ch1, c1)
    c2 = np.where(do, ch2, c2)
    first = rng.random(k) < 0.5
    return np.where(first[:, None], c1, c2)


def polynomial_mutation(rng, X, xl, xu, *, prob_var, eta=20.0):
    """Polynomial mutation (Deb & Goyal 1996, bounded form) of each variable with probability ``prob_var``."""
    X = X.copy()
    k, n = X.shape
    mut = rng.random((k, n)) < prob_var
    span = xu - xl
    d1, d2 = (X - xl) / span, (xu - X) / span
    r = rng.random((k, n))
    mp = 1.0 / (eta + 1.0)
    xy = np.where(r <= 0.5, 1.0 - d1, 1.0 - d2)
    val = np.where(
        r <= 0.5,
        2.0 * r + (1.0 - 2.0 * r) * np.power(xy, eta + 1.0),
        2.0 * (1.0 - r) + 2.0 * (r - 0.5) * np.power(xy, eta + 1.0),
    )
    dq = np.where(r <= 0.5, np.power(val, mp) - 1.0, 1.0 - np.power(val, mp))
    return np.where(mut, np.clip(X + dq * span, xl, xu), X)


# ------------------------------------------------------------------------------ algorithm
def bounded_replacement(
    cand: np.ndarray, g_new: np.ndarray, g_old: np.ndarray, cv_new: float, cv_old: np.ndarray, n_replace: int
) -> tuple[np.ndarray, np.ndarray]:
    """The slots one offspring takes: of the candidate slots ``cand`` (already in random order), those
    where it is better -- a lower aggregate ``g_new < g_old`` when both are feasible, else a lower
    constraint violation -- at most ``n_replace`` of them (Li and Zhang 2009's bound, which keeps one
    good offspring from filling a whole neighbourhood with copies of itself); their new aggregates."""
    both = (cv_new <= 0) & (cv_old <= 0)
    better = np.where(both, g_new < g_old, cv_new < cv_old)
    return cand[better][:n_replace], g_new[better][:n_replace]


def _violation(G: np.ndarray) -> np.ndarray:
    return np.maximum(G, 0.0).sum(axis=1) if G.shape[1] else np.zeros(len(G))


class MOEADBounded(Algorithm):
    """MOEA/D as a pymoo ``Algorithm`` (driven by :func:`pymoo.optimize.minimize`, like every optimiser
    here) on a ``Problem`` (``F`` and, if ``n_ieq_constr``, ``G <= 0`` feasible) with one subproblem per
    row of ``ref_dirs``. One pymoo iteration is the initial population, then one per generation (so
    ``n_gen`` generations are ``("n_gen", n_gen + 1)`` in pymoo's count). Its random numbers come from its
    own generator seeded by ``seed`` (the same stream whatever pymoo's seed).

    ``repair(X) -> X`` is applied to the first population and to every offspring; ``initial`` (designs)
    replaces the random first population (rows beyond the population are dropped, missing ones drawn).
    """

    def __init__(
        self,
        ref_dirs: np.ndarray,
        *,
        n_neighbors: int = 20,
        delta: float = 0.9,
        n_replace: int = 2,
        decomposition: str = "tchebycheff",
        theta: float = 5.0,
        seed: int = 0,
        crossover_prob: float = 0.6,
        mutation_prob: float = 0.05,
        sbx_eta: float = 15.0,
        pm_eta: float = 20.0,
        repair: Callable[[np.ndarray], np.ndarray] | None = None,
        initial: np.ndarray | None = None,
        **kwargs,
    ):
        super().__init__(**kwargs)
        self.ref_dirs = np.asarray(ref_dirs, dtype=float)
        pop_size = len(self.ref_dirs)
        if not 2 <= n_neighbors <= pop_size:
            raise ValueError(f"n_neighbors: must lie in [2, pop_size={pop_size}], got {n_neighbors}")
        if n_replace < 1:
            raise ValueError("n_replace: must be >= 1")
        if decomposition not in DECOMPOSITIONS:
            raise ValueError(f"decomposition: unknown {decomposition!r} (use one of {', '.join(DECOMPOSITIONS)})")
        self.n_neighbors, self.delta, self.n_replace = int(n_neighbors), float(delta), int(n_replace)
        self.decomposition, self.theta = decomposition, float(theta)
        self.moead_seed = int(seed)
        self.crossover_prob, self.mutation_prob = float(crossover_prob), float(mutation_prob)
        self.sbx_eta, self.pm_eta = float(sbx_eta), float(pm_eta)
        self.fix = repair if repair is not None else (lambda X: X)
        self.initial = None if initial is None else np.asarray(initial, dtype=float)

    def _setup(self, problem, **kwargs):
        self.rng = np.random.default_rng(self.moead_seed)
        self.xl, self.xu = np.asarray(problem.xl, dtype=float), np.asarray(problem.xu, dtype=float)
        W = self.ref_dirs
        dist = np.linalg.norm(W[:, None, :] - W[None, :, :], axis=2)
        self.B = np.argsort(dist, axis=1, kind="stable")[:, : self.n_neighbors]
        self.everyone = np.arange(len(W))

    def _initialize_infill(self):
        X = self.xl + self.rng.random((len(self.ref_dirs), self.problem.n_var)) * (self.xu - self.xl)
        if self.initial is not None:
            k = min(len(self.initial), len(X))
            X[:k] = self.initial[:k]
        return Population.new("X", self.fix(X))

    def _initialize_advance(self, infills=None, **kwargs):
        self.X = np.array(infills.get("X"), dtype=float)
        self.F, self.G = _values(infills)
        self.CV = _violation(self.G)
        self.z = (self.F[self.CV <= 0] if np.any(self.CV <= 0) else self.F).min(axis=0)
        self._sync()

    def _infill(self):
        rng, n = self.rng, len(self.ref_dirs)
        self.local = rng.random(n) < self.delta
        self.order = rng.permutation(n)
        P = np.array([rng.choice(self.B[i] if self.local[i] else self.everyone, 2, replace=False) for i in range(n)])
        X, xl, xu = self.X, self.xl, self.xu
        Y = sbx(rng, X[P[:, 0]], X[P[:, 1]], xl, xu, prob=self.crossover_prob, eta=self.sbx_eta)
        return Population.new(
            "X", self.fix(polynomial_mutation(rng, Y, xl, xu, prob_var=self.mutation_prob, eta=self.pm_eta))
        )

    def _advance(self, infills=None, **kwargs):
        Y = np.array(infills.get("X"), dtype=float)
        FY, GY = _values(infills)
        CVY = _violation(GY)
        X, F, G, CV, W, m = self.X, self.F, self.G, self.CV, self.ref_dirs, self.F.shape[1]
        # ideal and nadir, fixed within the generation
        if np.any(CVY <= 0):
            self.z = np.minimum(self.z, FY[CVY <= 0].min(axis=0))
        z = self.z
        feas = CV <= 0
        evaluated = np.all(F < NOT_EVALUATED, axis=1)  # not designs the exact rules kept from the simulator
        pool = F[feas] if feas.sum() >= 2 else (F[evaluated] if evaluated.any() else F)
        nadir = np.maximum(pool.max(axis=0), z + 1e-12)
        span = np.where(nadir - z > 1e-12, nadir - z, 1.0)
        g = aggregate((F - z) / span, W, self.decomposition, self.theta)
        FY_n = (FY - z) / span

        for i in self.order:  # bounded replacement, subproblems in random order
            cand = self.rng.permutation(self.B[i] if self.local[i] else self.everyone)
            gc = aggregate(np.broadcast_to(FY_n[i], (len(cand), m)), W[cand], self.decomposition, self.theta)
            hit, g_hit = bounded_replacement(cand, gc, g[cand], CVY[i], CV[cand], self.n_replace)
            if len(hit):
                X[hit], F[hit], G[hit], CV[hit] = Y[i], FY[i], GY[i], CVY[i]
                g[hit] = g_hit
        self._sync()

    def _sync(self):
        """pymoo's view of the population (the optimum it tracks, the result's ``pop``)."""
        self.pop = Population.new("X", self.X, "F", self.F, "G", self.G, "CV", self.CV[:, None])


def _values(pop) -> tuple[np.ndarray, np.ndarray]:
    F = np.array(pop.get("F"), dtype=float)
    G = pop.get("G")
    G = np.zeros((len(F), 0)) if G is None or np.size(G) == 0 else np.array(G, dtype=float).reshape(len(F), -1)
    return F, G


__all__ = ["DECOMPOSITIONS", "MOEADBounded", "aggregate", "bounded_replacement", "polynomial_mutation", "sbx"]
