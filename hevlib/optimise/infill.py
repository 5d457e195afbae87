"""The optimise stage's work: the oracle (simulator in the loop) and surrogate-assisted search with infill.

- :func:`oracle` -- any of the optimisers on the simulator itself (:class:`SimulatorModel`): the truth
  the surrogate method is measured against. Its front needs no re-simulation; every simulation counts.
- :func:`bayes` -- the BoTorch sources (:mod:`hevlib.optimise.bayesopt`): every design they judge is
  simulated, so their front is drawn from their archive as the oracle's is.
- :func:`surrogate_assisted` -- model management (Jin 2011's "evolution control" by generations):
  round 0 is the study's one-shot protocol (the surrogate fitted on the DOE, a full search, the front
  re-simulated); each further round adds the re-simulated candidates to the training data, refits the
  surrogate and resumes the search from the last population for ``infill.n_gen`` generations. The
  candidates of a round are at most ``infill.designs_per_round`` designs of the surrogate's front,
  chosen by :func:`select_candidates`. A round's front is the non-dominated set (simulated objectives)
  of every screen-passing candidate simulated so far, thinned to the population size
  (:func:`archive_front`); every round's front is kept (column ``round``), the last one is the
  source's final front.

Every simulation a source uses is counted in ``n_simulations`` (the DOE included for the surrogate
methods) and recorded when ``simulate`` is a :class:`~hevlib.optimise.archive.SimulationLog`; every round
is judged by the one hypervolume (:class:`HvSettings`) of that archive -- every simulated design that
passes the screen, not thinned (``archive_hypervolume``; the oracle is judged the same way) -- against
the oracle's archive when given. The thinned front's own hypervolume stays in ``hypervolume``.
"""

from __future__ import annotations

import dataclasses
import functools
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
import pyarrow as pa

from hevlib.design import DESIGN_VARS, OBJECTIVES, RESPONSES, DesignSpace
from hevlib.indicators import Normalisation, hv_greedy_subset, nondominated_mask, pick_diverse, to_minimisation
from hevlib.judging import HvSettings, objective_matrix
from hevlib.optimise.algorithms import Front, optimise
from hevlib.optimise.archive import SimulationLog
from hevlib.optimise.bayesopt import BayesSettings, bayes_search
from hevlib.optimise.problem import HevProblem, RulesOnly, SimulatorModel
from hevlib.optimise.report import front_report, runtimes
from hevlib.optimise.resim import drop_stalled, front_schema, front_table, resimulate
from hevlib.params import AlgoParams, BayesParams, InfillParams
from hevlib.screen import passes_screen
from hevlib.screen import speed_dev_max as speed_dev_rule

ROUND = "round"
#: Optimisers whose search an infill round resumes from the last population (``infill.n_gen``
#: generations). pymoo's NSGA-III and GA, resumed from a given population, did not reproduce exactly from
#: process to process (same inputs, different fronts), so their rounds restart from a seeded random
#: population at the full budget; MOEA/D is our own deterministic loop.
RESUMABLE = ("moead",)


@dataclass(frozen=True)
class StudyResult:
    """One source's run: its final front, the table of every round's rows, the report, the wall times."""

    front: Front
    table: pd.DataFrame
    report: dict
    runtimes: dict = field(default_factory=dict)
    simulated_X: np.ndarray | None = None  # every design simulated for this result (stalled included)
    responses: pd.DataFrame | None = None  # their responses, in the same order
    population: np.ndarray | None = None  # the optimiser's final population (to resume from)

    @property
    def schema(self) -> pa.Schema:
        """The table's schema: with ``round`` first when the table has it (the stage's Parquet)."""
        base = front_schema(self.front.std is not None)
        if ROUND in self.table.columns:
            return base.insert(0, pa.field(ROUND, pa.int64(), nullable=False))
        return base


def select_candidates(front: Front, k: int, criterion: str, span: np.ndarray) -> np.ndarray:
    """Indices of at most ``k`` designs of ``front`` to simulate (all of them when the front is no larger).

    Both criteria are greedy farthest-point sampling in the predicted objectives scaled by ``span``
    (the hypervolume's normalisation), so the candidates cover the front rather than one corner:

    - ``diverse``: starts from the design nearest the front's ideal point, then always takes the design
      farthest from those already taken;
    - ``uncertainty``: the same distances weighted by ``1 + u / mean(u)``, ``u`` the surrogate's mean
      standard deviation over the objectives in the same units, and starts from the most uncertain
      design: where the model knows least, a simulation teaches it most (falls back to ``diverse`` for
      a surrogate without a standard deviation).
    """
    n = len(front)
    if n <= k:
        return np.arange(n)
    F = to_minimisation(front.F) / span
    F = F - F.min(axis=0)
    if criterion == "uncertainty" and front.std is not None:
        u = np.mean(front.std / span, axis=1)
        weight = 1.0 + u / max(float(u.mean()), 1e-300)
        start = int(np.argmax(u))
    elif criterion in ("uncertainty", "diverse"):
        weight = np.ones(n)
        start = int(np.argmin(np.linalg.norm(F, axis=1)))
    else:
        raise ValueError(f"optimise.infill.criterion: unknown criterion {criterion!r}")
    if np.all(weight == 1.0):
        return np.sort(pick_diverse(F, k, start=start))
    chosen = [start]
    dist = np.linalg.norm(F - F[start], axis=1)
    for _ in range(k - 1):
        score = dist * weight
        score[chosen] = -1.0
        nxt = int(np.argmax(score))
        chosen.append(nxt)
        dist = np.minimum(dist, np.linalg.norm(F - F[nxt], axis=1))
    return np.sort(np.array(chosen))


def _subset(front: Front, idx: np.ndarray) -> Front:
    std = front.std[idx] if front.std is not None else None
    return dataclasses.replace(front, X=front.X[idx], F=front.F[idx], std=std)


def _simulate_front(front: Front, simulate, problem: HevProblem) -> tuple[Front, pd.DataFrame, pd.DataFrame, int]:
    """Re-simulate ``front``: (front without stalled designs, its table, all responses, stalled count)."""
    sim = resimulate(front.X, simulate) if len(front) else pd.DataFrame({c: [] for c in RESPONSES})
    kept, sim_kept, n_stalled = drop_stalled(front, sim)
    return kept, front_table(kept, sim_kept, problem), sim, n_stalled


def _ratio(hv: float, hv_oracle: float | None) -> float | None:
    return hv / hv_oracle if hv_oracle else None


def archive_table(archive: pd.DataFrame, problem: HevProblem, algo: str = "oracle") -> pd.DataFrame:
    """Every distinct design of a simulation archive (:data:`~hevlib.optimise.archive.ARCHIVE_SCHEMA`; its
    latest row) as a front table (:func:`~hevlib.optimise.resim.front_table`), the simulated objectives as
    the "predicted" ones: what a search on the simulator saw is what was simulated. ``problem`` must not
    carry the stalled callable (it would simulate again): its constraints read the objectives given. Without
    ``nondominated_sim``: :func:`archive_front` judges dominance among the designs it keeps (the whole
    archive's filter was 8 s of the oracle's 100 200 designs, and thrown away)."""
    df = archive.drop_duplicates(subset=list(DESIGN_VARS), keep="last").reset_index(drop=True)
    X = df[list(DESIGN_VARS)].to_numpy(dtype=float)
    sim = pd.DataFrame({k: df[f"sim_{k}"].to_numpy() for k in RESPONSES})
    F = sim[list(OBJECTIVES)].to_numpy(dtype=float)
    front = Front(algo, X, F, None, len(df), 0.0, len(df), 0)
    return front_table(front, sim, problem, dominance=False)


def oracle(
    make_problem: Callable[..., HevProblem],
    settings: AlgoParams,
    simulate: Callable[[np.ndarray], pd.DataFrame],
    hv: HvSettings,
    progress: Callable[[int, int], None] | None = None,
) -> StudyResult:
    """``settings.algorithm`` with the simulator as the model; ``make_problem(model, stalled)`` builds the
    same problem the surrogate methods solve (constraints on simulated figures, stalls infeasible).

    Every simulation is recorded (:class:`~hevlib.optimise.archive.SimulationLog`; ``simulate`` may be one
    already). The source's front, like every source's, is drawn from its archive (:func:`archive_front`:
    the screen-passing, non-dominated designs of everything it simulated, the hypervolume-greedy
    ``pop_size`` of them); nothing is simulated twice. ``StudyResult.responses`` holds the archive
    (:data:`~hevlib.optimise.archive.ARCHIVE_SCHEMA`). ``hv``: the hypervolume settings."""
    t0 = time.perf_counter()
    log = simulate if isinstance(simulate, SimulationLog) else SimulationLog(simulate)
    model = SimulatorModel(log)
    problem = make_problem(model, stalled=model.stalled)
    found = optimise(problem, settings.algorithm, settings, progress)
    n_pop = len(found.population) if found.population is not None else 0
    final = found.population if found.population is not None else found.X
    archive, front, table = _archive_result(log, final, make_problem, found, max(settings.pop_size, n_pop), hv)
    report = front_report(front, table, hv, settings=settings)
    judged = archive_hypervolume(archive, hv)
    report.update(
        algo="oracle",
        algorithm=settings.algorithm,
        surrogate=None,
        n_simulations=model.n_simulations,
        n_rejected_before_simulation=problem.n_not_evaluated,
        n_stalled_dropped=0,
        archive=judged,
        hv_ratio_to_oracle=1.0,
        rounds=[_round_entry(0, model.n_simulations, report, judged["hypervolume"], judged)],
    )
    wall = time.perf_counter() - t0
    times = {**runtimes(found, 0.0), "algo": "oracle", "runtime_total_s": wall}
    return StudyResult(front, table, report, times, responses=archive, population=found.population)


def _archive_result(
    log: SimulationLog, final, make_problem: Callable[..., HevProblem], found: Front, max_size: int, hv: HvSettings
) -> tuple[pd.DataFrame, Front, pd.DataFrame]:
    """A source whose search simulated every design it judged (the oracle, the BoTorch sources): its
    archive, and its front drawn from it (:func:`archive_front`), with the simulated objectives as ``F``."""
    archive = log.table(final).to_pandas()
    pool = archive_table(archive, make_problem(RulesOnly()))
    pool = pool[pool["feasible"] & ~pool["sim_stalled"].astype(bool)]  # the constraints the search had
    table = archive_front([pool], max_size, hv)
    Y = table[[f"sim_{k}" for k in OBJECTIVES]].to_numpy(dtype=float)
    front = dataclasses.replace(found, X=table[list(DESIGN_VARS)].to_numpy(dtype=float), F=Y, std=None)
    table = table.drop(columns=[c for c in table.columns if c.endswith("_std")])
    table.insert(0, ROUND, 0)
    return archive, front, table


def bayes(
    name: str,
    settings: BayesParams,
    make_problem: Callable[..., HevProblem],
    X_doe: np.ndarray,
    R_doe: pd.DataFrame,
    simulate: Callable[[np.ndarray], pd.DataFrame],
    hv: HvSettings,
    max_size: int,
    log_targets=(),
    hv_oracle: float | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> StudyResult:
    """A BoTorch source (:func:`hevlib.optimise.bayesopt.bayes_search`) from the DOE until
    ``settings.budget`` simulations (the DOE's included), judged like every source on its archive; its
    front is drawn from the archive as the oracle's is (thinned to ``max_size``)."""
    t0 = time.perf_counter()
    log = simulate if isinstance(simulate, SimulationLog) else SimulationLog(simulate)
    log.record(X_doe, R_doe)
    problem = make_problem(RulesOnly())
    space = DesignSpace(problem.xl, problem.xu)
    run = bayes_search(BayesSettings(**settings.model_dump()), problem, space, X_doe, R_doe, log, log_targets, progress)
    found = Front(name, run.X, np.zeros((len(run.X), len(OBJECTIVES))), None, len(run.X), 0.0, len(run.X), 0)
    archive, front, table = _archive_result(log, "last", make_problem, found, max_size, hv)
    report = front_report(front, table, hv, settings=settings)
    judged = archive_hypervolume(archive, hv)
    report.update(
        algo=name,
        acquisition=settings.acquisition,
        surrogate="gp",
        objectives_modelled=list(run.objectives),
        n_simulations=len(run.X),
        n_doe=int(len(X_doe)),
        n_rejected_before_simulation=run.n_rejected,
        n_stalled_dropped=0,
        archive=judged,
        hv_ratio_to_oracle=_ratio(judged["hypervolume"], hv_oracle),
        rounds=[_round_entry(0, len(run.X), report, hv_oracle, judged)],
    )
    wall = time.perf_counter() - t0
    times = {"algo": name, "runtime_total_s": wall, "rounds": run.rounds}
    return StudyResult(front, table, report, times, responses=archive)


def archive_hypervolume(archive: pd.DataFrame, hv: HvSettings) -> dict:
    """The judged figure of a source: the hypervolume (``hv``) of every design of its archive (every
    simulation so far, :data:`~hevlib.optimise.archive.ARCHIVE_SCHEMA`) that passes the screen, not
    thinned (``judged_object: archive``), with how it was computed."""
    h, n = hv.of(archive)
    return {"judged_object": "archive", "hypervolume": h.value, "hypervolume_se": h.se, "method": h.method,
            "points": h.n_points, "designs": n, "n_simulations": len(archive)}  # fmt: skip


def _round_entry(r: int, n_sims: int, report: dict, hv_oracle: float | None, archive: dict | None = None) -> dict:
    entry = {
        "round": r,
        "n_simulations": int(n_sims),
        "front_size": report["front_size"],
        "hypervolume": report["hypervolume"],
        "hypervolume_se": report["hypervolume_se"],
        "hypervolume_method": report["hypervolume_method"],
        "hv_ratio_to_oracle": _ratio(report["hypervolume"], hv_oracle),
    }
    if archive is not None:
        entry["archive_hypervolume"] = archive["hypervolume"]
        entry["archive_hypervolume_se"] = archive["hypervolume_se"]
        entry["hv_ratio_to_oracle"] = _ratio(archive["hypervolume"], hv_oracle)
    return entry


def optimise_and_resimulate(
    problem: HevProblem,
    algo: str,
    settings: AlgoParams,
    simulate: Callable[[np.ndarray], pd.DataFrame],
    hv: HvSettings,
    progress: Callable[[int, int], None] | None = None,
    *,
    initial: np.ndarray | None = None,
    n_candidates: int | None = None,
    criterion: str = "diverse",
    span: np.ndarray | None = None,
) -> StudyResult:
    """One round: search ``problem`` (from ``initial`` if given), re-simulate the front (at most
    ``n_candidates`` of it, chosen by :func:`select_candidates`), tabulate and report. With the defaults
    this is the study's one-shot protocol. ``span``: the objective scales the candidates are chosen in
    (the search's own, :func:`search_normalisation`; default ``hv.norm.span``).
    ``report["n_simulations"]`` counts this round's simulations;
    ``runtimes["responses"]`` holds every simulated row (stalled ones too: the infill loop learns from them)."""
    t0 = time.perf_counter()
    found = optimise(problem, algo, settings, progress, initial=initial)
    k = len(found) if n_candidates is None else int(n_candidates)
    candidates = _subset(found, select_candidates(found, k, criterion, hv.norm.span if span is None else span))
    t1 = time.perf_counter()
    front, table, sim, n_stalled = _simulate_front(candidates, simulate, problem)
    resim_s = time.perf_counter() - t1
    report = front_report(front, table, hv, settings=settings)
    report.update(n_simulations=len(candidates), n_stalled_dropped=n_stalled)
    times = {**runtimes(front, resim_s), "runtime_total_s": time.perf_counter() - t0}
    return StudyResult(front, table, report, times, candidates.X, sim, found.population)


#: Monte Carlo samples of the hypervolume-greedy thinning of a front (:func:`archive_front`).
SUBSET_SAMPLES = 100_000


def archive_front(tables: list[pd.DataFrame], max_size: int | None, hv: HvSettings) -> pd.DataFrame:
    """The source's front after a round: of every design simulated so far in this run, those that pass
    the screen (``hv.screen``; all when None) and that no other such design dominates (simulated
    objectives) -- a source returns the best of what it truly evaluated, not only its last batch. A
    design simulated in several rounds appears once (its latest row).

    In 11 objectives almost every design is non-dominated, so the front users see is thinned to
    ``max_size`` designs (the population size, the same for every source; None: not thinned) by greedy
    hypervolume selection (:func:`hevlib.indicators.hv_greedy_subset` on ``hv.norm`` up to
    ``hv.reference``, ``SUBSET_SAMPLES`` samples seeded by ``hv.seed``): each next design is the one that
    adds the most dominated volume, so the thinned front keeps as much of the archive's hypervolume as
    a greedy choice can (farthest-point thinning, used before, lost more than a random subset does)."""
    pool = pd.concat(tables, ignore_index=True).drop_duplicates(subset=list(DESIGN_VARS), keep="last")
    F = objective_matrix(pool, OBJECTIVES, what="simulated candidates")
    keep = nondominated_mask(F, among=passes_screen(pool, hv.screen) if hv.screen is not None and len(pool) else None)
    front = pool[keep].reset_index(drop=True)
    if max_size is not None and len(front) > max_size:
        Fn = hv.norm(objective_matrix(front, OBJECTIVES))
        idx = hv_greedy_subset(Fn, max_size, hv.reference, n_samples=SUBSET_SAMPLES, seed=hv.seed)
        front = front.iloc[idx].reset_index(drop=True)
    return front.assign(nondominated_sim=True)


def search_normalisation(Y: np.ndarray, speed_dev_max: float | None) -> Normalisation:
    """The scales a search chooses its candidates in: ideal and nadir (minimisation form) of its own
    training designs (the DOE and what it simulated) that follow the sizing cycle well enough
    (``speed_dev <= speed_dev_max``; all of them while fewer than two do). Never the judged normalisation:
    that one is built from the held-out set, which no search may see."""
    Y = np.asarray(Y, dtype=float)
    if speed_dev_max is None:
        follow = np.ones(len(Y), dtype=bool)
    else:
        follow = speed_dev_rule(speed_dev_max).mask({"speed_dev": Y[:, OBJECTIVES.index("speed_dev")]})
    return own_normalisation(to_minimisation(Y), follow)


def own_normalisation(F_min: np.ndarray, preferred: np.ndarray) -> Normalisation:
    """Ideal and nadir of a search's own designs (minimisation form): of the ``preferred`` ones (those
    that pass its screen) with finite objectives, or of every finite one while fewer than two do."""
    finite = np.all(np.isfinite(F_min), axis=1)
    use = finite & preferred if np.count_nonzero(finite & preferred) >= 2 else finite
    return Normalisation.from_points(F_min[use])


def _round_progress(progress: Callable, algo: str, r: int, rounds: int, done: int, total: int) -> None:
    """Report a search's generations with its round: ``moead: round 2/4, 120/200 gen``."""
    progress(done, total, f"{algo}: round {r}/{rounds}, {done}/{total} gen")


def surrogate_assisted(
    algo: str,
    settings: AlgoParams,
    infill: InfillParams,
    make_problem: Callable[..., HevProblem],
    fit: Callable[[np.ndarray, np.ndarray], object],
    X_doe: np.ndarray,
    Y_doe: np.ndarray,
    simulate: Callable[[np.ndarray], pd.DataFrame],
    hv: HvSettings,
    hv_oracle: float | None = None,
    progress: Callable[[int, int], None] | None = None,
    max_simulations: int | None = None,
) -> StudyResult:
    """Rounds 0..``infill.rounds`` of fit -> search -> re-simulate candidates -> add to training data.
    With ``max_simulations``, stops after the round that reaches that many simulations (DOE included),
    or after a round that found nothing new to simulate (the benchmark's budgets).

    ``fit(X, Y)`` returns a fitted surrogate (only ever on the DOE and the designs this run simulated:
    never the held-out set); ``make_problem(model)`` the problem on it. Returns the last round's front,
    every round's rows (column ``round``) and the report with ``rounds`` and ``n_simulations`` (DOE
    included).
    """
    X_train, Y_train = np.asarray(X_doe, dtype=float), np.asarray(Y_doe, dtype=float)
    log = simulate if isinstance(simulate, SimulationLog) else None  # its archive is what the source is judged on
    n_sims, n_stalled = len(X_train), 0
    population, tables, entries, times, res, archive = None, [], [], [], None, []
    for r in range(infill.rounds + 1):
        t0 = time.perf_counter()
        problem = make_problem(fit(X_train, Y_train))
        span = search_normalisation(Y_train, getattr(problem, "speed_dev_max", None)).span
        resume = r > 0 and algo in RESUMABLE
        round_settings = settings.model_copy(update={"n_gen": infill.n_gen}) if resume else settings
        res = optimise_and_resimulate(
            problem,
            algo,
            round_settings,
            simulate,
            hv,
            None if progress is None else functools.partial(_round_progress, progress, algo, r, infill.rounds),
            initial=population if resume else None,
            n_candidates=infill.designs_per_round,
            criterion=infill.criterion,
            span=span,
        )
        population = res.population
        n_sims += res.report["n_simulations"]
        n_stalled += res.report["n_stalled_dropped"]
        Y_new = res.responses[list(OBJECTIVES)].to_numpy(dtype=float)
        ok = np.all(np.isfinite(Y_new), axis=1)
        X_train, Y_train = np.vstack([X_train, res.simulated_X[ok]]), np.vstack([Y_train, Y_new[ok]])
        archive.append(res.table)
        front_r = archive_front(archive, max(settings.pop_size, len(res.population)), hv)
        report_r = front_report(res.front, front_r, hv, settings=round_settings)
        tables.append(front_r.assign(**{ROUND: r})[[ROUND, *front_r.columns]])
        judged = archive_hypervolume(log.table("all").to_pandas(), hv) if log is not None else None
        entries.append(_round_entry(r, n_sims, report_r, hv_oracle, judged))
        times.append({"round": r, "runtime_s": time.perf_counter() - t0, "n_simulations": n_sims})
        if max_simulations is not None and (n_sims >= max_simulations or res.report["n_simulations"] == 0):
            break
    report = report_r
    report.update(
        settings={**settings.model_dump(), **res.front.settings},
        n_simulations=int(n_sims),
        n_doe=int(len(X_doe)),
        n_stalled_dropped=n_stalled,
        hv_ratio_to_oracle=entries[-1]["hv_ratio_to_oracle"],
        archive=judged,
        rounds=entries,
        infill=infill.model_dump(),
    )
    wall = sum(t["runtime_s"] for t in times)
    table = pd.concat(tables, ignore_index=True)
    return StudyResult(res.front, table, report, {"algo": algo, "runtime_total_s": wall, "rounds": times})


__all__ = [
    "ROUND",
    "SUBSET_SAMPLES",
    "archive_front",
    "archive_hypervolume",
    "archive_table",
    "bayes",
    "StudyResult",
    "optimise_and_resimulate",
    "oracle",
    "own_normalisation",
    "search_normalisation",
    "select_candidates",
    "surrogate_assisted",
]
