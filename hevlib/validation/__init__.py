"""Validate the picked designs against the conventional car and the stock Prius (the study's Table 8), and
recommend one. One module per job:

- :mod:`~hevlib.validation.runs` -- simulate the picks and both baselines on every validation cycle (the
  validation table), traces and the cold-start window;
- :mod:`~hevlib.validation.improvement` -- the improvement tables ('+' = better) and engine downsizing;
- :mod:`~hevlib.validation.recommendation` -- eligibility, the design to build, the best of each group, the
  twins and the near-equivalents (typed: :mod:`hevlib.results`);
- :mod:`~hevlib.validation.bags` -- the FTP bag by bag;
- :mod:`~hevlib.validation.trust` -- the trust of each source: its model's held-out quality, flagged where
  worse than a constant on an objective it optimises;
- :mod:`~hevlib.validation.gap` -- the controller's gap in the answer (``hev bound``'s table);
- :mod:`~hevlib.validation.summary` -- ``reports/validation.json``, ``headline.json`` and ``answer.json``.

This package's face names what the stages use.
"""

from hevlib.validation.bags import FTP_BAGS_S, bag_figures, ftp_bags
from hevlib.validation.gap import check_covers, recommended_gap
from hevlib.validation.improvement import (
    ALL,
    BASELINE_ALGO,
    BASELINES,
    IMPROVEMENT_RESPONSES,
    MAXIMISED,
    NO_BATTERY,
    SOC_POINTS,
    engine_downsizing,
    group_rows,
    improvement,
    improvement_table,
)
from hevlib.validation.recommendation import (
    RECOMMENDED_RESPONSES,
    eligible_ids,
    failed_cycles,
    recommendation,
    simulate_twins,
    twins_schema,
)
from hevlib.validation.runs import (
    best_design,
    cold_start_window_s,
    cycle_notes,
    load_cycles,
    prius_design,
    split_cycle,
    traces,
    validation_schema,
    validation_table,
)
from hevlib.validation.summary import ANSWER_KEYS, answer, headline, seed_spread, summarise
from hevlib.validation.trust import found_by, source_trust

__all__ = [
    "ALL",
    "ANSWER_KEYS",
    "BASELINES",
    "BASELINE_ALGO",
    "FTP_BAGS_S",
    "IMPROVEMENT_RESPONSES",
    "MAXIMISED",
    "NO_BATTERY",
    "RECOMMENDED_RESPONSES",
    "SOC_POINTS",
    "answer",
    "bag_figures",
    "best_design",
    "cold_start_window_s",
    "cycle_notes",
    "eligible_ids",
    "engine_downsizing",
    "failed_cycles",
    "found_by",
    "ftp_bags",
    "group_rows",
    "headline",
    "improvement",
    "improvement_table",
    "load_cycles",
    "prius_design",
    "recommendation",
    "check_covers",
    "recommended_gap",
    "seed_spread",
    "simulate_twins",
    "source_trust",
    "split_cycle",
    "summarise",
    "traces",
    "twins_schema",
    "validation_schema",
    "validation_table",
]
