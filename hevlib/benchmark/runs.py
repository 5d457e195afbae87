"""One benchmark run: a source, a seed, and every simulation it made, in order.

A run's record (:data:`RUN_SCHEMA`) has one row per simulation -- ``sim_index`` 1, 2, ... in the order
the simulator was called, the DOE's designs first for the surrogate-assisted sources (every simulation
counts) -- with the design, its simulated responses (``sim_`` names) and ``final_population`` (the rows
of the source's final population: the optimiser's last population for the direct searches and the
oracle, the last infill batch for the SAEAs, every row for Latin-hypercube sampling). Nothing is
thinned or filtered here: the scoring (:mod:`hevlib.benchmark.scoring`) judges every source on the same
object built from these rows.

Sources (``params.benchmark.sources``):

- ``nsga3``, ``moead``, ``moga`` -- the study's surrogate-assisted pairs (BNN, BNN, regressions) with the
  infill of ``params.optimise.infill``, rounds until the budget;
- ``parego``, ``nehvi`` -- BoTorch's qLogNParEGO and qLogNEHVI (:mod:`hevlib.optimise.bayesopt`) with the
  settings of ``params.optimise.bayes`` but the benchmark's budget, from the same DOE;
- ``tsparego`` -- batch Thompson-sampling ParEGO on pathwise GP samples (:mod:`hevlib.optimise.tsparego`) with
  the settings of ``params.optimise.tsparego`` at the benchmark's budget, from the same DOE;
- ``nsga3_direct``, ``moead_direct`` -- the same optimisers on the simulator at small populations;
- ``lhs`` -- a seeded Latin hypercube, integers and gear sets repaired as the optimisers' are;
- ``oracle`` -- ``params.optimise.oracle`` (the study's 200 x 500 on the simulator).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd
import pyarrow as pa

from hevlib.design import DESIGN_VARS, OBJECTIVES
from hevlib.indicators import Normalisation, to_minimisation
from hevlib.judging import HvSettings, screened_normalisation, simulated_as_front
from hevlib.optimise.archive import ARCHIVE_SCHEMA, SimulationLog
from hevlib.optimise.bayesopt import BayesSettings, bayes_search
from hevlib.optimise.infill import oracle, surrogate_assisted
from hevlib.optimise.problem import RulesOnly, admissible_lhs
from hevlib.optimise.tsparego import TsParegoSettings, tsparego
from hevlib.params import BENCHMARK_SOURCES, AlgoParams, Params
from hevlib.surrogates import fit_surrogate

BAYES = ("parego", "nehvi", "tsparego")  # Bayesian optimisation on BoTorch's models, from the DOE
SAEA = ("nsga3", "moead", "moga", *BAYES)
DIRECT = ("nsga3_direct", "moead_direct", "lhs")
CEILING = ("oracle",)
KIND = {**dict.fromkeys(SAEA, "saea"), **dict.fromkeys(DIRECT, "direct"), "oracle": "oracle"}

RUN_SCHEMA = ARCHIVE_SCHEMA


def run_seed(root: int, source: str, run: int) -> int:
    """The seed of run ``run`` of ``source``: ``SeedSequence([root, source index, run])`` as one int."""
    return int(np.random.SeedSequence([int(root), BENCHMARK_SOURCES.index(source), int(run)]).generate_state(1)[0])


def n_runs(cfg: Params, source: str) -> int:
    b = cfg.benchmark
    return b.oracle_seeds if source == "oracle" else b.seeds


@dataclass
class RunContext:
    """What every run needs: params, the simulator call, the problem factory and the DOE."""

    cfg: Params
    simulate: Callable[[np.ndarray], pd.DataFrame]
    make_problem: Callable[..., object]
    X_doe: np.ndarray
    R_doe: pd.DataFrame
    progress: Callable[[int, int], None] | None = None


def run_source(ctx: RunContext, source: str, run: int) -> pa.Table:
    """Run ``source`` once (run index ``run``, its seed from :func:`run_seed`); its record."""
    if source not in BENCHMARK_SOURCES:
        raise ValueError(f"benchmark: unknown source {source!r} (use one of {', '.join(BENCHMARK_SOURCES)})")
    seed = run_seed(ctx.cfg.benchmark.seed, source, run)
    log = SimulationLog(ctx.simulate)
    if source in ("nsga3", "moead", "moga"):
        final = _saea(ctx, source, seed, log)
    elif source in BAYES:
        final = _bayes(ctx, source, seed, log)
    elif source == "lhs":
        final = _lhs(ctx, seed, log)
    else:
        final = _direct(ctx, source, seed, log)
    return log.table(final)


def _hv_cheap(ctx: RunContext):
    """Hypervolume settings for the optimisers' own round reports (not the benchmark's judgement: the
    scoring recomputes everything from the record), cheap and on a normalisation of the DOE alone."""
    doe = simulated_as_front(ctx.R_doe.assign(**{v: ctx.X_doe[:, j] for j, v in enumerate(DESIGN_VARS)}))
    try:
        norm = screened_normalisation([doe], ctx.cfg.screen)
    except ValueError:
        norm = Normalisation.from_points(to_minimisation(ctx.R_doe[list(OBJECTIVES)].to_numpy(dtype=float)))
    return HvSettings(norm, n_samples=1000, seed=0, screen=ctx.cfg.screen, exact_max_points=0)


def _saea(ctx: RunContext, source: str, seed: int, log: SimulationLog) -> str:
    cfg = ctx.cfg
    settings: AlgoParams = cfg.optimise.algorithms[source].model_copy(update={"seed": seed % (2**31)})
    infill = cfg.optimise.infill
    infill = infill.model_copy(update={"rounds": 100})  # until the budget (max_simulations), at most 100
    surrogate_cfg = cfg.surrogate.model_copy(update={"bnn": cfg.surrogate.bnn.model_copy(update={"seed": seed})})
    space = cfg.design_space.space()
    log.record(ctx.X_doe, ctx.R_doe)
    Y_doe = ctx.R_doe[list(OBJECTIVES)].to_numpy(dtype=float)
    ok = np.all(np.isfinite(Y_doe), axis=1)

    def fit(X, Y):
        return fit_surrogate(settings.surrogate, X, Y, surrogate_cfg, space)

    surrogate_assisted(
        source, settings, infill, ctx.make_problem, fit, ctx.X_doe[ok], Y_doe[ok], log, _hv_cheap(ctx),
        progress=ctx.progress, max_simulations=cfg.benchmark.budget,
    )  # fmt: skip
    return "last"


def _bayes(ctx: RunContext, source: str, seed: int, log: SimulationLog) -> str:
    cfg = ctx.cfg
    if source == "tsparego":
        search = tsparego
        settings = TsParegoSettings(**cfg.optimise.tsparego.model_dump(), budget=cfg.benchmark.budget, seed=seed)
    else:
        b = cfg.optimise.bayes.get(source)
        if b is None:
            raise ValueError(f"benchmark: source {source} needs optimise.bayes.{source} in params.yaml")
        search = bayes_search
        settings = BayesSettings(**b.model_dump(exclude={"budget", "seed"}), budget=cfg.benchmark.budget, seed=seed)
    log.record(ctx.X_doe, ctx.R_doe)
    problem = ctx.make_problem(RulesOnly())
    search(
        settings, problem, cfg.design_space.space(), ctx.X_doe, ctx.R_doe, log, cfg.surrogate.bnn.log_targets,
        ctx.progress,
    )  # fmt: skip
    return "last"


def _lhs(ctx: RunContext, seed: int, log: SimulationLog) -> str:
    log(admissible_lhs(ctx.make_problem(RulesOnly()), ctx.cfg.design_space.space(), ctx.cfg.benchmark.budget, seed))
    return "all"


def _direct(ctx: RunContext, source: str, seed: int, log: SimulationLog) -> np.ndarray:
    cfg = ctx.cfg
    if source == "oracle":
        settings = cfg.optimise.oracle.model_copy(update={"seed": seed % (2**31)})
    else:
        algo = source.removesuffix("_direct")
        d = getattr(cfg.benchmark, source)
        base = cfg.optimise.oracle.model_copy(update={"algorithm": algo})
        if algo == "moead":
            moead = cfg.optimise.algorithms.get("moead")
            extra = {k: getattr(moead, k) for k in ("delta", "n_replace", "decomposition")} if moead else {}
            base = base.model_copy(update={**extra, "n_neighbors": d.n_neighbors})
        pop = d.pop_size
        n_gen = max(1, math.ceil(cfg.benchmark.direct_budget / pop) - 1)
        settings = base.model_copy(update={"pop_size": pop, "n_gen": n_gen, "seed": seed % (2**31)})
    hv = _hv_cheap(ctx)
    result = oracle(ctx.make_problem, settings, log, hv, progress=ctx.progress)
    pop = result.front.population
    return pop if pop is not None else result.front.X


__all__ = [
    "CEILING",
    "DIRECT",
    "KIND",
    "RUN_SCHEMA",
    "SAEA",
    "RunContext",
    "SimulationLog",
    "n_runs",
    "run_seed",
    "run_source",
]
