"""Typed results of the pareto step, the validation step and the recommendation, and their one JSON form.

:mod:`hevlib.pareto` and :mod:`hevlib.validation` build them, ``hev pareto`` and ``hev validate`` write them
(``reports/pareto.json``, ``reports/validation.json``) and :mod:`hevlib.report` reads their attributes. Tables
whose keys are data (an algorithm, a cycle, a response) stay mappings; what has a fixed shape is a frozen
dataclass. :func:`to_json` is the one serialiser: fields in declaration order (the order of the JSON keys), a
field marked :data:`OMIT_NONE` left out while it is ``None``. :func:`from_json` reads the form back into the
types, so a report can be rebuilt from the file.
"""

from __future__ import annotations

import dataclasses
import types
import typing
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

#: Field metadata: leave the key out of the JSON while the value is None (instead of writing null).
OMIT_NONE = {"omit_none": True}

#: A response's figure, or None where it is undefined (e.g. a SOC figure against the conventional car).
Figure = float | None

#: ``ValidationSummary.seed_spread_status`` where no seed-spread study is on disk.
SEED_SPREAD_NOT_MEASURED = "not measured: `dvc repro benchmarks/robustness/dvc.yaml` measures the seed spread"


def to_json(obj: Any) -> Any:
    """``obj`` as plain JSON types: dataclasses as objects in field order, mappings and sequences recursively."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        out = {}
        for f in dataclasses.fields(obj):
            value = getattr(obj, f.name)
            if value is None and f.metadata.get("omit_none"):
                continue
            out[f.name] = to_json(value)
        return out
    if isinstance(obj, Mapping):
        return {k: to_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_json(v) for v in obj]
    return obj


def from_json(cls: type, data: Any) -> Any:
    """The JSON form ``data`` (as :func:`to_json` writes it) read back as ``cls``."""
    return _read(cls, data)


def _read(tp: Any, data: Any) -> Any:
    if data is None:
        return None
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        inner = [a for a in typing.get_args(tp) if a is not type(None)]
        return _read(inner[0], data) if len(inner) == 1 else data
    if dataclasses.is_dataclass(tp):
        hints = typing.get_type_hints(tp)
        return tp(**{f.name: _read(hints[f.name], data[f.name]) for f in dataclasses.fields(tp) if f.name in data})
    if origin is dict:
        _, value = typing.get_args(tp)
        return {k: _read(value, v) for k, v in data.items()}
    if origin is list:
        (item,) = typing.get_args(tp)
        return [_read(item, v) for v in data]
    return data


@dataclass(frozen=True)
class ParetoCounts:
    """Designs at each step of the pareto stage."""

    input: int
    duplicates_removed: int
    merged: int
    non_finite: int
    nondominated: int
    feasible: int
    kept: int
    picked: int


@dataclass(frozen=True)
class Selection:
    """How the kept designs were ranked and the validated ones picked, and the shortlist's roles."""

    rank_rule: str
    n_keep: int
    n_pick: int
    pick: str
    seed: int | None
    pick_rule: str
    #: role (knee, best of a group) -> the design holding it
    roles: dict[str, str]


@dataclass(frozen=True)
class SourceSummary:
    """One source judged on the common object (its screened archive) and scale, with its front and picks."""

    judged_object: str
    hypervolume: float
    hypervolume_se: float
    hypervolume_method: str
    hypervolume_points: int
    hypervolume_designs: int
    hv_ratio_to_oracle: Figure
    front_hypervolume: float
    front_hypervolume_se: float
    front_hv_ratio_to_oracle: Figure
    n_simulations: int | None
    archive_size: int
    front_size: int
    picked: int
    picked_share: float
    spread: dict[str, float]
    seed_spread: str


@dataclass(frozen=True)
class Judging:
    """How every source was judged: the object, the one normalisation and hypervolume, and each source."""

    judged_object: str
    judged_object_means: str
    hv_reference: float
    normalisation: dict[str, Any]
    hypervolume: dict[str, Any]
    sources: dict[str, SourceSummary]


@dataclass(frozen=True)
class ParetoSummary:
    """``reports/pareto.json``: merge, screen, rank and pick counts (overall, per screen rule, per source), the
    selection, notes; with the stage's :class:`Judging` of every source and the design box's active bounds."""

    counts: ParetoCounts
    #: screen rule -> {enabled, rule, fails_alone, removed_in_sequence}
    screen: dict[str, dict[str, Any]]
    by_algo: dict[str, dict[str, int]]
    shared_designs: int
    kept_share: dict[str, float]
    picked_share: dict[str, float]
    selection: Selection
    notes: list[str]
    judged_object: str | None = field(default=None, metadata=OMIT_NONE)
    judged_object_means: str | None = field(default=None, metadata=OMIT_NONE)
    hv_reference: float | None = field(default=None, metadata=OMIT_NONE)
    normalisation: dict[str, Any] | None = field(default=None, metadata=OMIT_NONE)
    hypervolume: dict[str, Any] | None = field(default=None, metadata=OMIT_NONE)
    sources: dict[str, SourceSummary] | None = field(default=None, metadata=OMIT_NONE)
    active_bounds: dict[str, Any] | None = field(default=None, metadata=OMIT_NONE)

    def judged(self, judging: Judging, active_bounds: dict[str, Any]) -> ParetoSummary:
        """The same summary with the stage's judging of every source and the active bounds of the kept designs."""
        fields = {f.name: getattr(judging, f.name) for f in dataclasses.fields(judging)}
        return dataclasses.replace(self, **fields, active_bounds=active_bounds)


@dataclass(frozen=True)
class HighwayRule:
    """The screen's highway rule as the recommendation applied it."""

    enabled: bool
    min_v_max_kmh: float
    picks_below: list[str]


@dataclass(frozen=True)
class Pick:
    """A validated design: its variables, why it stands where it does (bounds touched, screen margins, active
    rules), the validation cycles it fails, and its figures against both baselines on every cycle
    (``by_cycle[cycle]``: ``design``, each baseline, and ``vs_<baseline>`` improvements in %)."""

    design_id: str
    algo: str
    rank: int | None
    design: dict[str, float]
    bounds_touched: list[dict[str, Any]]
    screen_margins: dict[str, dict[str, Any]]
    active_rules: list[str]
    fails: list[str]
    by_cycle: dict[str, dict[str, dict[str, Any]]]
    #: bag-by-bag FTP figures of this design and both baselines (the recommended design on FTP only)
    ftp_bags: dict[str, list[dict[str, Any]]] | None = field(default=None, metadata=OMIT_NONE)


@dataclass(frozen=True)
class Noise:
    """The model's noise at the eligible picks (their twins' scatter of the knee criteria) and how often each
    pick is the knee when every pick is drawn as itself or one of its twins."""

    method: str
    twins: int
    share_of_range: float
    draws: int
    min_share: float
    seed: int
    sigma: dict[str, Figure]
    sigma_pct_of_mean: dict[str, Figure]
    knee_share: dict[str, float]


@dataclass(frozen=True)
class Equivalent:
    """A near-equivalent of the recommended design: the knee in at least ``Noise.min_share`` of the draws."""

    design_id: str
    algo: str
    knee_share: float
    design: dict[str, float]
    criteria: dict[str, Figure]
    vs_recommended: dict[str, dict[str, Figure]]
    separated_by: list[dict[str, Any]]
    same_family: bool


@dataclass(frozen=True)
class Recommendation:
    """The design to build, the best pick of each objective group, the model's noise and the near-equivalents."""

    cycle: str
    preference: str
    criteria: list[str]
    groups: dict[str, list[str]]
    eligible: int
    pool_rule: str
    highway_rule: HighwayRule
    design: Pick | None
    best: dict[str, Pick | None]
    noise: Noise | None
    equivalents: list[Equivalent]

    def with_ftp_bags(self, bags: dict[str, list[dict[str, Any]]]) -> Recommendation:
        """The same recommendation, its design carrying its FTP bag figures."""
        return dataclasses.replace(self, design=dataclasses.replace(self.design, ftp_bags=bags))


@dataclass(frozen=True)
class Counts:
    """How many picks were validated, per source, and which vehicles met and charge-balanced each cycle."""

    picked: int
    by_algo: dict[str, int]
    cycle_met: dict[str, dict[str, Any]]
    charge_balanced: dict[str, dict[str, Any]]
    #: vehicle -> the validation cycles it did not follow
    failed_cycles: dict[str, list[str]]


@dataclass(frozen=True)
class SourceTrust:
    """How far one source's picks can be trusted: what it searched on (``model``: ``bnn``, ``regression``,
    ``gp``, ``simulator`` or ``unknown``), the objectives it optimises, that model's held-out R² on each (None:
    not measured) and the objectives on which it is worse than a constant (held-out R² below 0). ``flagged``: at
    least one such objective."""

    source: str
    searched_on: str
    model: str
    objectives: list[str]
    heldout_r2: dict[str, Figure] | None
    worse_than_constant: list[str]
    flagged: bool
    note: str


@dataclass(frozen=True)
class Trust:
    """The trust of each source in the answer: every surrogate's held-out R² per objective (the surrogates
    stage's ``reports/surrogate_metrics.json``; ``r2``: every held-out design, the one the rule reads;
    ``r2_followers``: the held-out designs that follow the sizing cycle), the rule, each merged source and the
    flagged ones (a surrogate worse than a constant on an objective it optimises)."""

    metrics: str
    split: str
    rule: str
    n_heldout: dict[str, int]
    r2: dict[str, dict[str, Figure]]
    r2_followers: dict[str, dict[str, Figure]]
    sources: dict[str, SourceTrust]
    flagged: list[str]


@dataclass(frozen=True)
class ValidationSummary:
    """``reports/validation.json``: the picks against both baselines on the headline cycle (improvement tables
    per source, in %; ``all`` = every pick), counts, engine downsizing, absolute means, the other cycles'
    tables, the recommendation, the trust of each source (its model's held-out quality), the seed spread
    (null unless the robustness study was made with this run's settings and code) and the controller's gap."""

    cycle: str
    improvement: dict[str, dict[str, dict[str, Figure]]]
    units: dict[str, str]
    counts: Counts
    engine_downsizing_pct: dict[str, Figure]
    mean_p_eng_kw: dict[str, Figure]
    p_eng_conventional_kw: float
    absolute: dict[str, dict[str, Any]]
    by_cycle: dict[str, dict[str, Any]]
    best_design: str | None
    recommendation: Recommendation | None = field(default=None, metadata=OMIT_NONE)
    #: each merged source's trust (:class:`Trust`), where the stage read the surrogates' held-out metrics
    trust: Trust | None = field(default=None, metadata=OMIT_NONE)
    #: the seed-spread study's figures, only where it was made with this run's settings and code (else null)
    seed_spread: dict[str, Any] | None = None
    #: whether ``seed_spread`` holds this run's figures, and if not, how to make them
    seed_spread_status: str = SEED_SPREAD_NOT_MEASURED
    #: the controller's gap (:func:`hevlib.validation.gap.recommended_gap` of ``hev bound``'s table): every pick's and
    #: both reference cars' fuel under the rule base, ECMS and the bound, the headline saving under each; omitted
    #: where the stage ran without it (``hev validate --no-gap``: the seed-spread replicates)
    controller_gap: dict[str, Any] | None = field(default=None, metadata=OMIT_NONE)


__all__ = [
    "OMIT_NONE",
    "SEED_SPREAD_NOT_MEASURED",
    "Counts",
    "Equivalent",
    "HighwayRule",
    "Judging",
    "Noise",
    "ParetoCounts",
    "ParetoSummary",
    "Pick",
    "Selection",
    "SourceSummary",
    "SourceTrust",
    "Recommendation",
    "Trust",
    "ValidationSummary",
    "from_json",
    "to_json",
]
