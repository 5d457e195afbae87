"""The equal-budget, many-seed benchmark of every source of designs (issue 24).

- :mod:`~hevlib.benchmark.runs` -- one run of one source: every simulation it made, in order;
- :mod:`~hevlib.benchmark.scoring` -- one judged object, one normalisation, common Monte Carlo samples,
  anytime curves, IGD+ and the statistics;
- :mod:`~hevlib.benchmark.report` -- ``reports/benchmark/``: summary.json, curves and the plot.
"""
