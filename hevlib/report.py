"""``reports/summary.md``: the page an engineer reads after ``dvc repro`` (built by the validate stage).

:func:`build_summary` is a pure function of the stage results (the pareto and validation summaries,
the validation table, the selected designs) and of the plot paths, relative to the summary file.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from hevlib.design import DESIGN_VARS, OBJECTIVES, UNITS
from hevlib.recommend import FAMILY_SHARE
from hevlib.results import ParetoSummary, Pick, Recommendation, Trust, ValidationSummary
from hevlib.validation import ALL, BASELINE_ALGO, IMPROVEMENT_RESPONSES, SOC_POINTS, found_by
from hevlib.validation.trust import MODELS, R2_BELOW

#: The study's headline against the conventional car on FTP (SPEC section 1).
STUDY_HEADLINE = {
    "engine downsizing": "about 40 % (70 kW to about 42 kW)",
    "m_veh": "about 4 % lower",
    "fc": "36-46 % lower",
}


def _labelled(name: str) -> str:
    """A column header: the name with its unit (:data:`hevlib.design.UNITS`), bare for a share or a flag."""
    unit = UNITS.get(name, "-")
    return name if unit in ("-", "bool") else f"{name} [{unit}]"


def _fmt(value, digits: int = 3) -> str:
    if value is None or (isinstance(value, float) and not np.isfinite(value)):
        return "n/a"
    if isinstance(value, bool | np.bool_):
        return "yes" if value else "no"
    if isinstance(value, int | np.integer):
        return str(int(value))
    if isinstance(value, float | np.floating):
        v = float(value)
        if v != 0 and abs(v) < 10 ** -(digits + 1):
            return f"{v:.{digits - 1}e}"
        return f"{v:.0f}" if abs(v) >= 10 ** (digits + 1) else f"{v:.{digits + 1}g}"
    return str(value)


def markdown_table(header: Sequence[str], rows: Sequence[Sequence], digits: int = 3) -> str:
    """A GitHub-flavoured markdown table; numbers formatted, None/NaN as ``n/a``."""
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(_fmt(v, digits) for v in row) + " |" for row in rows]
    return "\n".join(lines)


def improvement_markdown(improvement: Mapping, comparison: str) -> str:
    """Rows = responses, columns = algorithms and ``all``, for one comparison (``vs_conventional``...)."""
    groups = list(improvement)
    header = ["response", "unit", *groups]
    rows = []
    for r in IMPROVEMENT_RESPONSES:
        unit = "SOC points" if r in SOC_POINTS else "%"
        rows.append([r, unit, *[_round(improvement[g][comparison].get(r)) for g in groups]])
    return markdown_table(header, rows)


def _round(v):
    return None if v is None else round(float(v), 2) + 0.0  # + 0.0: no "-0"


def _pareto_section(pareto: ParetoSummary) -> list[str]:
    c = pareto.counts
    out = ["## Merge, screen and select (sizing cycle, simulated objectives)", ""]
    out.append(
        markdown_table(
            ["step", "designs"],
            [
                ["designs on the fronts", c.input],
                ["identical designs merged", c.duplicates_removed],
                ["distinct designs", c.merged],
                ["non-finite objectives (dropped)", c.non_finite],
                ["non-dominated", c.nondominated],
                ["feasible after screening", c.feasible],
                ["kept (best by rank)", c.kept],
                ["picked for validation", c.picked],
            ],
        )
    )
    out += [
        "",
        "Screening rules, applied in this order to the non-dominated designs "
        "(a rule switched off removes nothing but is still counted):",
        "",
    ]
    out.append(
        markdown_table(
            ["rule", "on", "criterion", "fails alone", "removed in sequence"],
            [
                [name, r["enabled"], r["rule"], r["fails_alone"], r["removed_in_sequence"]]
                for name, r in pareto.screen.items()
            ],
        )
    )
    algos = list(pareto.by_algo)
    out += [
        "",
        markdown_table(
            ["algorithm", "front", "non-dominated", "feasible", "kept", "picked", "share of kept", "share of picked"],
            [
                [
                    a,
                    b["input"],
                    b["nondominated"],
                    b["feasible"],
                    b["kept"],
                    b["picked"],
                    round(pareto.kept_share[a], 3),
                    round(pareto.picked_share[a], 3),
                ]
                for a, b in pareto.by_algo.items()
            ],
        )
        if algos
        else "",
    ]
    sources = pareto.sources or {}
    if sources:
        out += [
            "",
            "Sources, each judged on the same object: its archive -- every design it simulated (the DOE "
            "included for the surrogate-assisted ones) that passes the screen, not thinned -- by the "
            "hypervolume of the simulated objectives, normalised by the ideal and nadir of the judged scale (the "
            "screen-passing designs of `hev judge`'s reference set, which no source produced), reference "
            f"{pareto.hv_reference:g} (exact up to {pareto.hypervolume.get('exact_max_points', 'n/a')} non-dominated "
            "designs, beyond that Monte Carlo with its standard error); the ratio is to the oracle's archive, "
            "the best-known front at its budget (not the truth). One seed each: whether a source beats another "
            "is decided by the many-seed, equal-budget benchmark (`reports/benchmark/summary.json`), not here. "
            "`front` is the hypervolume-greedy subset each source hands on (the same size for every source):",
            "",
            markdown_table(
                [
                    "source",
                    "simulations",
                    "hypervolume",
                    "± (1 s.e.)",
                    "method",
                    "ratio to oracle",
                    "front",
                    "front HV",
                    "picked",
                    "share of picks",
                ],
                [
                    [
                        a,
                        v.n_simulations,
                        v.hypervolume,
                        v.hypervolume_se,
                        v.hypervolume_method,
                        v.hv_ratio_to_oracle,
                        v.front_size,
                        v.front_hypervolume,
                        v.picked,
                        round(v.picked_share, 3),
                    ]
                    for a, v in sources.items()
                ],
            ),
            "",
            "![Archive hypervolume ratio to the oracle's archive against simulations, per infill round]"
            "(plots/pareto/infill.png)",
        ]
    sel = pareto.selection
    out += [
        "",
        f"Rank: {sel.rank_rule}. Pick: `{sel.pick}`"
        + (f" (seed {sel.seed})" if sel.seed is not None else " (farthest-point sampling)")
        + f", n_keep={sel.n_keep}, n_pick={sel.n_pick}. "
        f"{pareto.shared_designs} distinct design(s) were found by more than one algorithm "
        "(they count for each, so shares can add up to more than 1).",
    ]
    for note in pareto.notes:
        out.append(f"\n> Note: {note}.")
    return out


def _algo_cell(algo: str, trust: Trust | None) -> str:
    """The source(s) that found a design, marked where every one of them is flagged (:func:`_trust_lines`)."""
    return f"{algo} **(flagged)**" if found_by(algo, trust)[1] else str(algo)


def _designs_table(
    table: pd.DataFrame, selected: pd.DataFrame, cycle: str, fails: Mapping, trust: Trust | None = None
) -> str:
    rows = table[table["cycle"] == cycle]
    role = (
        dict(zip(selected["design_id"].astype(str), selected["pick_role"], strict=True))
        if "pick_role" in selected
        else {}
    )
    rank = dict(zip(selected["design_id"].astype(str), selected["rank"], strict=True)) if "rank" in selected else {}
    order = list(rows[rows["algo"] != BASELINE_ALGO]["vehicle"]) + ["prius", "conventional"]
    rows = rows.set_index("vehicle").loc[[v for v in order if v in set(rows["vehicle"])]]
    cols = [*IMPROVEMENT_RESPONSES, "t_0_100_s", "cycle_met"]
    header = [
        "vehicle",
        "algo",
        "rank",
        "role",
        *DESIGN_VARS,
        *[_labelled(c) for c in cols],
        "fails",
    ]
    body = [
        [
            v,
            r["algo"] if v in ("prius", "conventional") else _algo_cell(r["algo"], trust),
            rank.get(v),
            role.get(v) or "",
            *[r[x] for x in DESIGN_VARS],
            *[r[c] for c in cols],
            ", ".join(f"**{c}**" for c in fails.get(v, [])) or "none",
        ]
        for v, r in rows.iterrows()
    ]
    return markdown_table(header, body)


def _design_line(d: Pick) -> str:
    x = d.design
    return ", ".join(f"{v} = {_fmt(x[v])}" for v in DESIGN_VARS)


def _reasons_lines(d: Pick) -> list[str]:
    out = []
    touched = d.bounds_touched
    out.append(
        "- Bounds of the design box it touches: "
        + (
            ", ".join(f"`{b['variable']}` at its {b['side']} bound {b['bound']:g}" for b in touched)
            + " -- the optimum may lie beyond: consider widening them"
            if touched
            else "none"
        )
        + "."
    )
    margins = d.screen_margins
    if margins:
        out.append(
            "- Margin to the screen (value against limit; a rule within 5 % of its limit is active): "
            + "; ".join(
                f"`{name}` {_fmt(m['value'])} vs {_fmt(m['limit'])} ({'on' if m['enabled'] else 'off'}"
                + (", **active**" if m["active"] else f", {100 * -m['margin']:.1f} % to spare")
                + ")"
                for name, m in margins.items()
            )
            + "."
        )
    fails = d.fails
    out.append("- Validation cycles it fails: " + (", ".join(f"**{c}**" for c in fails) if fails else "none") + ".")
    return out


def _equivalents_lines(rec: Recommendation) -> list[str]:
    """The model's noise at the eligible picks and the recommendation's near-equivalents, with what separates
    each from it (``recommendation.noise``, ``recommendation.equivalents``)."""
    noise = rec.noise
    if not noise:
        return []
    d = rec.design
    sig = ", ".join(
        f"{_labelled(c)} ±{_fmt(noise.sigma[c])} ({_round(noise.sigma_pct_of_mean[c])} %)" for c in noise.sigma
    )
    own = 100 * noise.knee_share.get(d.design_id, 0.0)
    others = sorted(((v, k) for k, v in noise.knee_share.items() if k != d.design_id and v > 0), reverse=True)
    out = [
        f"**Within the model's noise.** Twins of each eligible pick, its continuous variables moved by at most "
        f"{100 * noise.share_of_range:g} % of their ranges, scatter the knee criteria by {sig} (root mean square). "
        f"With every pick drawn as itself or one of its {noise.twins} twins, {d.design_id} is the knee in "
        f"{own:.0f} % of {noise.draws} draws"
        + ("; " + ", ".join(f"{k} in {100 * v:.1f} %" for v, k in others) if others else "")
        + ".",
        "",
    ]
    eq = rec.equivalents
    if not eq:
        return out + [
            f"No other eligible pick is the knee in {100 * noise.min_share:g} % of the draws or more: the model's "
            "noise does not swap the answer.",
            "",
        ]
    crit = list(noise.sigma)
    rows = [
        [
            e.design_id,
            e.algo,
            _round(100 * e.knee_share),
            *[e.criteria[c] for c in crit],
            *[_round(e.vs_recommended[c]["pct"]) for c in crit],
            "; ".join(f"{s['variable']} {_fmt(s['recommended'])} → {_fmt(s['this'])}" for s in e.separated_by)
            or f"nothing beyond {100 * FAMILY_SHARE:g} % of a range (same family)",
        ]
        for e in eq
    ]
    return out + [
        f"Near-equivalents: the knee in at least {100 * noise.min_share:g} % of the draws, so the same answer as "
        f"{d.design_id} (another seed or machine that recommends one of them agrees with this one):",
        "",
        markdown_table(
            [
                "design",
                "found by",
                "knee in % of draws",
                *[_labelled(c) for c in crit],
                *[f"Δ {c} %" for c in crit],
                f"separated by (variables more than {100 * FAMILY_SHARE:g} % of their range apart)",
            ],
            rows,
        ),
        "",
    ]


def _seed_spread_lines(validation: ValidationSummary, robustness: Mapping | None) -> list[str]:
    """The headline's seed spread next to this run's single-seed figures (``hev robustness``): only from a study
    made with this run's settings and code (``robustness["current"]``); else one line saying how to make it."""
    out = ["### Across seeds (the seed spread of this answer)", ""]
    if not robustness:
        return out + [
            "No robustness study on disk: `dvc repro benchmarks/robustness/dvc.yaml` measures the seed spread.",
            "",
        ]
    if not robustness.get("current"):
        return out + [
            "The seed-spread study on disk (`reports/robustness/summary.json`) was made with other settings or code "
            "(another car, cycle, profile or commit), so none of its figures are shown here: "
            "`dvc repro benchmarks/robustness/dvc.yaml` measures the seed spread of this run.",
            "",
        ]
    n = robustness["replicates"]
    rec = validation.recommendation
    this = rec.design.design_id if rec is not None and rec.design is not None else None
    status = "made with these settings and code"
    rows = []
    for key, label in (
        ("rec_fc_cb_pct", "recommended design's charge-balanced saving vs conventional [%]"),
        ("fc_cb_pct", "picks' mean charge-balanced saving vs conventional [%]"),
        ("fc_vs_prius_pct", "picks' mean fuel saving vs the stock Prius, study's protocol [%]"),
        ("mass_pct", "picks' mean mass saving [%]"),
    ):
        sp = robustness["spread"].get(key, {})
        if sp.get("n"):
            rows.append([label, sp["replicate_0"], sp["mean"], sp["std"], sp["min"], sp["max"]])
    same = sum(1 for d in robustness["recommended"] if d["default_answer"])
    runs = {r["replicate"]: r for r in robustness["runs"]}
    out += [
        f"The chain after the surrogates (every source, the screen, validation) rerun with {n} seeds per source "
        f"(`hev robustness`, `reports/robustness/summary.json`, {status}). Seeds of params.yaml: recommended "
        f"{robustness['runs'][0]['recommended']}"
        + (f" (this run: {this})" if this and this != robustness["runs"][0]["recommended"] else "")
        + f". The recommended design is the default answer -- of its family (every variable within "
        f"{100 * robustness['family_share_of_range']:g} % of its range) or a near-equivalent's -- in {same} of the "
        f"{len(robustness['recommended'])} replicates (replicate 0 included):",
        "",
        markdown_table(["figure", "params' seeds", "mean", "sd", "min", "max"], rows),
        "",
        "Where the recommended designs of the replicates lie (share of the design box they span): "
        + ", ".join(
            f"{v} {_fmt(r['min'])}–{_fmt(r['max'])} ({100 * r['share_of_range']:.0f} %)"
            for v, r in robustness.get("variable_range", {}).items()
        )
        + ".",
        "",
        markdown_table(
            ["replicate", "recommended", "found by", "the default answer?", "rec_fc_cb_pct", "p_eng_kw"],
            [
                [
                    d["replicate"],
                    d["design_id"],
                    d["algo"],
                    d["default_answer_as"] or "no: another answer",
                    runs[d["replicate"]]["answer"].get("rec_fc_cb_pct"),
                    d["design"]["p_eng_kw"],
                ]
                for d in robustness["recommended"]
            ],
        ),
        "",
    ]
    return out


def _controller_gap_lines(validation: ValidationSummary) -> list[str]:
    """The controller's gap in the answer (``validation.controller_gap``, from ``hev bound``'s table): per cycle the
    recommended design's and both reference cars' fuel under every controller, how much more each burns than the
    bound, the headline saving under each, and the shortlist's fuel under each with its least-fuel design."""
    gap = validation.controller_gap
    if not gap:
        return []
    names = list(gap["controllers"])
    rec = gap["recommended"]
    out = [
        "### How much the controller leaves on the table (`hev bound`)",
        "",
        "Fuel on each cycle under the study's rule base, ECMS in the drive step (`pms.strategy: ecms`), ECMS on the "
        "bound's model and the bound (dynamic programming over SOC: the least any controller could burn on the same "
        f"hardware and trace); {gap['yardstick']}. Details and the bound's grid convergence: `reports/bound.md`.",
        "",
    ]
    header = ["cycle", "vehicle", *[f"{n} [L/100 km]" for n in names], *[f"{n} over bound" for n in names[:-1]]]
    rows, savings = [], []
    for cycle, c in gap["by_cycle"].items():
        for v in (rec, "prius", "conventional"):
            entry = c["vehicles"].get(v)
            if entry is None:
                continue
            label = f"{v} (recommended)" if v == rec else v
            over = [None if x is None else f"{x:+.1f} %" for x in (entry["over_bound_pct"][n] for n in names[:-1])]
            rows.append([cycle, label, *[entry["fc_l_100km"][n] for n in names], *over])
        if c["saving_pct"]:
            sv = c["saving_pct"]
            savings.append(
                f"{cycle}: "
                + ", ".join(
                    f"{n} {'n/a' if sv[n] is None else format(sv[n], '.1f') + ' %'}" for n in [*names, "bound_both"]
                )
            )
    out += [markdown_table(header, rows), ""]
    if savings:
        out += [
            "The recommended design's fuel saving against the conventional car (under its shift logic; `bound_both`: "
            "both at their bounds), under each controller: " + "; ".join(savings) + ".",
            "",
        ]
    first, c = next(iter(gap["by_cycle"].items()))
    picks = {v: e for v, e in c["vehicles"].items() if v not in ("prius", "conventional")}
    least = {
        n: min(
            (v for v in picks if picks[v]["fc_l_100km"][n] is not None),
            key=lambda v: picks[v]["fc_l_100km"][n],
            default=None,
        )
        for n in names
    }
    out += [
        f"The shortlist on {first} under each controller (least fuel: "
        + ", ".join(f"{n} {least[n] or 'n/a'}" for n in names)
        + "):",
        "",
        markdown_table(
            ["design", *[f"{n} [L/100 km]" for n in names], "note"],
            [[v, *[e["fc_l_100km"][n] for n in names], e["note"]] for v, e in picks.items()],
        ),
        "",
    ]
    return out


def _r2_cell(v) -> str:
    """A held-out R², bold where below :data:`~hevlib.validation.trust.R2_BELOW` (worse than a constant)."""
    if v is None:
        return "n/a"
    text = _fmt(float(v), 2)
    return f"**{text}**" if v < R2_BELOW else text


def _trust_lines(validation: ValidationSummary) -> list[str]:
    """Trust of each source in the answer: every surrogate's held-out R² per objective, flagged cells, and a
    line per merged source (what it searched on; flagged where that model is worse than a constant on an
    objective it optimises; not measured where nothing measures it)."""
    trust = validation.trust
    if trust is None:
        return []
    n = trust.n_heldout
    rows = []
    for split, table, what in (
        ("heldout", trust.r2, "all {n} held-out designs"),
        ("heldout_followers", trust.r2_followers, "the {n} that follow the cycle"),
    ):
        for model, r2 in table.items():
            rows.append(
                [f"{MODELS.get(model, model)}, {what.format(n=n.get(split, 'n/a'))}"]
                + [_r2_cell(r2.get(o)) for o in OBJECTIVES]
            )
    out = [
        "## Trust of each source",
        "",
        "Every pick's figures are simulated and hold; what the model a source searched on decides is whether the "
        "front it handed on lies near the best designs. Held-out R² of the surrogates (`"
        + trust.metrics
        + "`: the models fitted on every DOE design, which round 0 of every surrogate-assisted optimiser searches; "
        "infill rounds refit them on more designs, which nothing judges on held-out designs). **Bold**: below "
        f"{R2_BELOW:g}, worse than predicting the held-out designs' mean. The rule, on all held-out designs (the "
        f"first rows): {trust.rule}.",
        "",
    ]
    if rows:
        out += [markdown_table(["model (held-out designs)", *OBJECTIVES], rows), ""]
    else:
        out += ["No held-out metrics of the surrogates on disk: `hev surrogates` writes them.", ""]
    for name, t in trust.sources.items():
        out.append(f"- **{name}** ({t.searched_on}): " + ("**flagged**: " if t.flagged else "") + t.note + ".")
    flagged = trust.flagged
    out += [
        "",
        (
            f"**Flagged: {', '.join(flagged)}.** Their fronts were merged with the others'; a pick from them is the "
            "best design their models led to, not necessarily the best there is -- trust it as far as the oracle "
            "or another sound source finds designs like it."
        )
        if flagged
        else "No source is flagged: no surrogate is worse than a constant on an objective its source optimises.",
        "",
    ]
    return out


def _trust_line(d: Pick, trust: Trust | None) -> list[str]:
    """Which source(s) the recommended design comes from and how far their models can be trusted."""
    if trust is None:
        return []
    names = [a for a in str(d.algo).split("+") if a in trust.sources]
    if not names:
        return []
    flagged = found_by(d.algo, trust)[1]
    return [
        ("**Trust: flagged.** " if flagged else "Trust: ")
        + "; ".join(f"From {trust.sources[a].searched_on}: {trust.sources[a].note}" for a in names)
        + (
            ". Its figures below are simulated, but the front it came from may lie far from the best designs "
            "(see Trust of each source)."
            if flagged
            else "."
        ),
        "",
    ]


def _build_this(validation: ValidationSummary, pareto: ParetoSummary, robustness: Mapping | None = None) -> list[str]:
    rec = validation.recommendation
    if not rec:
        return []
    d = rec.design
    out = ["## Build this", ""]
    if d is None:
        return out + ["> No design could be recommended: no pick has finite validation figures.", ""]
    out += [
        f"**{d.design_id}** (found by {found_by(d.algo, validation.trust)[0]}, rank {d.rank} of the kept designs): "
        f"{_design_line(d)}.",
        "",
        *_trust_line(d, validation.trust),
        f"Why this one: the {rec.preference} ({rec.eligible} of the {validation.counts.picked} picks"
        + (")." if rec.pool_rule == "eligible" else f"; {rec.pool_rule})."),
        "",
        *_reasons_lines(d),
        "",
        *_equivalents_lines(rec),
        *_seed_spread_lines(validation, robustness),
        *_controller_gap_lines(validation),
    ]
    for cycle, fig in d.by_cycle.items():
        rows = []
        for r in (x for x in fig["design"] if x != "cycle_met"):
            rows.append(
                [
                    _labelled(r),
                    fig["design"][r],
                    fig["prius"][r],
                    fig["conventional"][r],
                    _round(fig["vs_prius"].get(r)),
                    _round(fig["vs_conventional"].get(r)),
                ]
            )
        rows.append(["cycle met", *[fig[k]["cycle_met"] for k in ("design", "prius", "conventional")], None, None])
        out += [
            f"### {cycle}" + (" (headline cycle)" if cycle == rec.cycle else ""),
            "",
            markdown_table(
                ["figure", d.design_id, "stock Prius", "conventional", "% better than Prius", "% better than conv."],
                rows,
            ),
            "",
        ]
    bags = d.ftp_bags
    if bags:
        out += [
            "### FTP bag by bag (each hybrid from the SOC its charge-balanced run started at)",
            "",
            markdown_table(
                ["vehicle", "bag", "seconds", "km", "fc [L/100 km]", "hc [g/km]", "co [g/km]", "nox [g/km]", "ΔSOC"],
                [
                    [
                        v,
                        b["bag"],
                        f"{b['start_s']:g}-{b['end_s']:g}",
                        b["distance_km"],
                        b["fc"],
                        b["hc"],
                        b["co"],
                        b["nox"],
                        b["delta_soc"],
                    ]
                    for v, rows in bags.items()
                    for b in rows
                ],
            ),
            "",
        ]
    best = rec.best
    if best:
        out += [
            f"### The best pick of each objective group on {validation.cycle} (same eligibility; the `role` column "
            "of Selected designs names each design's role on the sizing cycle, where the pareto stage chose it)",
            "",
            markdown_table(
                [
                    "group",
                    "criterion",
                    "design",
                    "fc_charge_balanced [L/100 km]",
                    "m_veh [kg]",
                    "t_0_100_s [s]",
                    "bounds touched",
                    "fails",
                ],
                [
                    [
                        g,
                        " + ".join(rec.groups[g]),
                        b.design_id,
                        b.by_cycle[rec.cycle]["design"]["fc_charge_balanced"],
                        b.by_cycle[rec.cycle]["design"]["m_veh"],
                        b.by_cycle[rec.cycle]["design"]["t_0_100_s"],
                        ", ".join(f"{t['variable']} {t['side']}" for t in b.bounds_touched) or "none",
                        ", ".join(b.fails) or "none",
                    ]
                    for g, b in best.items()
                    if b is not None
                ],
            ),
            "",
        ]
    hw = rec.highway_rule
    out.append(
        f"Highway rule (`screen.min_v_max_kmh`): {'on' if hw.enabled else 'off'} at {hw.min_v_max_kmh:g} km/h; "
        f"{len(hw.picks_below)} of the picks fall short of it in the flat-road top-speed test."
    )
    ab = pareto.active_bounds
    if ab:
        out += ["", f"Active bounds of the design box (kept designs): {ab['advice']}."]
    return out + [""]


def _headline(validation: ValidationSummary) -> list[str]:
    imp = validation.improvement[ALL]["vs_conventional"]
    down = validation.engine_downsizing_pct[ALL]
    mean = validation.absolute["mean_of_picks"][ALL]
    return [
        markdown_table(
            ["figure (all picks vs conventional car)", "study", "this run"],
            [
                [
                    "engine downsizing",
                    STUDY_HEADLINE["engine downsizing"],
                    "n/a"
                    if down is None
                    else f"{down:.1f} % ({validation.p_eng_conventional_kw:g} kW to {mean_p_eng(validation):.1f} kW)",
                ],
                ["test mass", STUDY_HEADLINE["m_veh"], _pct(imp.get("m_veh"), "lower")],
                [
                    f"charge-balanced fuel consumption ({validation.cycle}, SAE J1711 within 1 %)",
                    "-",
                    _pct(imp.get("fc_charge_balanced"), "lower"),
                ],
                [
                    f"fuel consumption ({validation.cycle}, the study's protocol: from SOC 0.7, not balanced)",
                    STUDY_HEADLINE["fc"],
                    _pct(imp.get("fc"), "lower"),
                ],
                ["SOC-corrected fuel consumption", "-", _pct(imp.get("fc_soc_corrected"), "lower")],
                ["mean charge-balanced FC of the picks [L/100 km]", "-", _fmt(mean.get("fc_charge_balanced"))],
                ["mean FC of the picks [L/100 km] (study's protocol)", "-", _fmt(mean.get("fc"))],
            ],
        )
    ]


def mean_p_eng(validation: ValidationSummary) -> float:
    v = validation.mean_p_eng_kw.get(ALL)
    return np.nan if v is None else float(v)


def _pct(v, word: str) -> str:
    if v is None:
        return "n/a"
    other = "higher" if word == "lower" else "lower"
    return f"{v:.1f} % {word}" if v >= 0 else f"{-v:.1f} % {other}"


def build_summary(
    pareto: ParetoSummary,
    validation: ValidationSummary,
    table: pd.DataFrame,
    selected: pd.DataFrame,
    plots: Mapping[str, str],
    notes: Sequence[str] = (),
    robustness: Mapping | None = None,
) -> str:
    """The whole ``summary.md`` text. ``plots`` maps a caption to a path relative to the summary; ``robustness``:
    ``reports/robustness/summary.json`` with ``current`` (whether it was made with these settings and code)."""
    cycle = validation.cycle
    imp = validation.improvement
    fails = validation.counts.failed_cycles
    out = [
        "# hev-sizing: selection and validation summary",
        "",
        *_build_this(validation, pareto, robustness),
        *_trust_lines(validation),
        "## How to read the rest",
        "",
        "Generated by `hev validate` (do not edit): improvements are means over the picked designs, "
        "'+' = better. Minimised responses: 100 (base - design) / |base|; maximised (v_max, f_max, "
        "eta_drivetrain): 100 (design - base) / |base|; diff_soc (SOC at start - SOC at end): "
        "base - design in SOC percentage points, not applicable against the conventional car "
        "(no traction battery). A design found by several algorithms counts for each.",
        "",
        "Fuel figures: `fc_charge_balanced` (first in every table, the one to quote) is each hybrid's fuel on a run "
        "whose battery ends where it started (rerun from its end SOC until the net battery energy is within "
        "1 % of the fuel energy, SAE J1711; null where a run did not balance); `fc` is the study's protocol "
        "(from SOC 0.7, the battery's net energy not corrected); `fc_soc_corrected` converts that net energy to "
        "fuel at the run's own engine and generator efficiencies. The conventional car has one figure for all three.",
        "",
    ]
    if not validation.counts.picked:
        worst = max(pareto.screen.items(), key=lambda kv: kv[1]["removed_in_sequence"], default=None)
        out += [
            "> **No design passed the screening, so nothing was validated and the improvement tables are "
            "empty.**"
            + (
                f" The rule that removed most designs: `{worst[0]}` ({worst[1]['rule']}, "
                f"{worst[1]['removed_in_sequence']} removed); see the screening table below."
                if worst
                else ""
            ),
            "",
        ]
    out += [
        f"## Improvement on {cycle} (headline)",
        "",
        "### Against the conventional car",
        "",
        improvement_markdown(imp, "vs_conventional"),
        "",
        "### Against the stock Prius",
        "",
        improvement_markdown(imp, "vs_prius"),
        "",
    ]
    down = validation.engine_downsizing_pct
    out += [
        "Engine downsizing (mean p_eng_kw of the picks against the conventional engine, '+' = smaller): "
        + ", ".join(f"{g} {'n/a' if v is None else _fmt(_round(v)) + ' %'}" for g, v in down.items())
        + ".",
        "",
    ]
    out += ["### Against the study's headline", "", *_headline(validation), ""]
    met = validation.counts.cycle_met
    out += [
        "Cycle met (picks / conventional / Prius): "
        + "; ".join(
            f"{c}: {m['picked']} of {validation.counts.picked} / {_fmt(m.get('conventional'))} / {_fmt(m.get('prius'))}"
            for c, m in met.items()
        )
        + ".",
        "",
    ]
    for other, sec in validation.by_cycle.items():
        failing = sorted(v for v, cs in fails.items() if other in cs and v not in ("prius", "conventional"))
        out += [
            f"## Robustness check: {other}",
            "",
            f"Picks that fail {other}: "
            + (", ".join(f"**{v}**" for v in failing) if failing else "none")
            + " (their figures are in the means below).",
            "",
            "### Against the conventional car",
            "",
            improvement_markdown(sec["improvement"], "vs_conventional"),
            "",
            "### Against the stock Prius",
            "",
            improvement_markdown(sec["improvement"], "vs_prius"),
            "",
        ]
    out += [
        f"## Selected designs ({cycle} results)",
        "",
        "`role`: why the shortlist holds a design, on the sizing cycle where the pareto stage chose it (knee, best "
        f"of a group there, which need not be the best on {cycle}; blank: farthest-point fill); `fails`: "
        "the validation cycles a vehicle did not follow (more than "
        "`sim.cycle_met_tolerance_kmh` off the trace, or stalled) -- marked wherever the design appears; "
        "`algo`: the source(s) that found it, **(flagged)** where every one searched a model worse than a constant "
        "on an objective it optimises (Trust of each source).",
        "",
        _designs_table(table, selected, cycle, fails, validation.trust),
        "",
    ]
    out += _pareto_section(pareto) + [""]
    if plots:
        out += ["## Plots", ""]
        for caption, path in plots.items():
            out += [f"### {caption}", "", f"![{caption}]({path})", ""]
    if notes:
        out += ["## Notes", ""] + [f"- {n}" for n in notes] + [""]
    return "\n".join(out)


__all__ = ["build_summary", "markdown_table", "improvement_markdown", "STUDY_HEADLINE"]
