"""Many-objective sizing (SPEC section 8), by role:

- :mod:`~hevlib.optimise.problem` -- :class:`HevProblem` (seven variables, eleven minimised objectives,
  the mass constraint and the screen's rules as constraints) on any model: a surrogate, or the simulator
  itself (:class:`SimulatorModel`); the integer repair.
- :mod:`~hevlib.optimise.algorithms` -- NSGA-III, MOEA/D and the weighted-sum GA, each
  ``(problem, settings, progress, initial) -> Front``; :func:`optimise` dispatches by name.
- :mod:`~hevlib.optimise.bayesopt` -- Bayesian optimisation on BoTorch (qLogNParEGO, qLogNEHVI on a
  reduced objective set) with a failure model and the exact rules as linear constraints.
- :mod:`~hevlib.optimise.infill` -- the stage's work: :func:`oracle` (simulator in the loop),
  :func:`bayes` (the BoTorch sources) and :func:`surrogate_assisted` (round 0 = the study's one-shot
  protocol, then infill rounds).
- :mod:`~hevlib.optimise.resim` -- re-simulating a front and its table (``data/pareto/<source>.parquet``).
- :mod:`~hevlib.optimise.report` -- the hypervolume every source is judged by, surrogate error, reports.
"""

from hevlib.optimise.algorithms import (
    ALGORITHMS,
    Front,
    estimate_normalisation,
    moead,
    moga,
    nsga3,
    optimise,
    reference_directions,
    run,
    weighted_sum_ranks,
)
from hevlib.optimise.infill import (
    ROUND,
    StudyResult,
    bayes,
    optimise_and_resimulate,
    oracle,
    select_candidates,
    surrogate_assisted,
)
from hevlib.optimise.problem import HevProblem, IntegerRepair, SimulatorModel
from hevlib.optimise.report import front_report, runtimes, surrogate_error
from hevlib.optimise.resim import drop_stalled, front_schema, front_table, resimulate

BAYES_SOURCES = ("parego", "nehvi")
SOURCES = (*ALGORITHMS, *BAYES_SOURCES, "oracle")

__all__ = [
    "ALGORITHMS",
    "BAYES_SOURCES",
    "ROUND",
    "SOURCES",
    "Front",
    "HevProblem",
    "bayes",
    "IntegerRepair",
    "SimulatorModel",
    "StudyResult",
    "drop_stalled",
    "estimate_normalisation",
    "front_report",
    "front_schema",
    "front_table",
    "moead",
    "moga",
    "nsga3",
    "optimise",
    "optimise_and_resimulate",
    "oracle",
    "reference_directions",
    "resimulate",
    "run",
    "runtimes",
    "select_candidates",
    "surrogate_assisted",
    "surrogate_error",
    "weighted_sum_ranks",
]
