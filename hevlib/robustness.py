"""How stable the answer is across seeds (``hev robustness``; its own pipeline, benchmarks/robustness/dvc.yaml).

The default pipeline gives one answer for one set of seeds. A replicate reruns the chain after the surrogates
-- every source of ``optimise.sources`` (the oracle first), then ``pareto`` and ``validate`` -- with other seeds
for every source, on the same DOE, held-out set, cycles and components. Replicate 0 keeps the seeds of
``params.yaml`` (it must reproduce the default pipeline's answer byte for byte); replicate ``k >= 1`` gives
source ``s`` the seed ``SeedSequence([robustness.seed, index of s, k])``.

Each replicate runs the ``hev`` stage commands themselves in a folder of its own
(``data/robustness/runs/rep_<k>/``: its ``params.yaml``, links to the shared inputs, and every output the chain
writes), so the chain is exactly the default pipeline's; its figures are collected into ``result.json``, which
is kept while the settings and the code are unchanged (:func:`fingerprint`), so an interrupted study resumes.

:func:`summarise` reports how often each recommended design comes out -- the same design, and the same
*family* (every variable within :data:`hevlib.recommend.FAMILY_SHARE` of its range: a design another seed finds
may differ in the last digits and be the same car) -- whether it is the default answer or one of its
near-equivalents (``recommendation.equivalents``), and the spread of the headline figures over the replicates.
"""

from __future__ import annotations

import copy
import hashlib
import json
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import yaml

from hevlib.codedeps import closure_hash, import_closure
from hevlib.design import DESIGN_VARS
from hevlib.doe import simulation_fingerprint
from hevlib.params import load_params
from hevlib.recommend import FAMILY_SHARE, KNEE_CRITERIA, same_family
from hevlib.results import Equivalent, Pick, ValidationSummary, from_json

#: Every source a replicate can reseed, in the order their seeds are derived (an index into this tuple).
SEEDED_SOURCES: tuple[str, ...] = ("nsga3", "moead", "moga", "oracle", "parego", "nehvi")  # new ones at the end
#: The headline figures whose seed spread is reported (``reports/answer.json``'s short keys).
SPREAD_KEYS: tuple[str, ...] = ("rec_fc_cb_pct", "fc_cb_pct", "fc_pct", "fc_vs_prius_pct", "mass_pct", "p_eng_kw")
#: Inputs a replicate shares with the default pipeline (linked into its folder, never written).
SHARED_INPUTS: tuple[str, ...] = ("data/cycles", "data/components", "data/doe", "data/judge")
#: Code a replicate runs (besides the simulator, which the params' simulation fingerprint covers).
RUN_MODULES: tuple[str, ...] = ("stages.optimise", "stages.pareto", "stages.validate")


def replicate_seed(root: int, source: str, replicate: int) -> int:
    """The seed of ``source`` in replicate ``replicate >= 1``: ``SeedSequence([root, source index, replicate])``."""
    ss = np.random.SeedSequence([int(root), SEEDED_SOURCES.index(source), int(replicate)])
    return int(ss.generate_state(1)[0])


def replicate_seeds(raw: Mapping, replicate: int) -> dict[str, int]:
    """``{source: seed}`` of a replicate for the sources of the raw params mapping (replicate 0: its own)."""
    o = raw["optimise"]
    root = int(raw.get("robustness", {}).get("seed", 3636))
    out = {}
    for source in o.get("sources", SEEDED_SOURCES):
        own = _seed_node(o, source).get("seed", 0)
        out[source] = int(own) if replicate == 0 else replicate_seed(root, source, replicate)
    return out


def _seed_node(o: Mapping, source: str) -> Mapping:
    """The params node that holds ``source``'s seed (``optimise.oracle``, ``.algorithms.<s>`` or ``.bayes.<s>``)."""
    if source == "oracle":
        return o["oracle"]
    return o["algorithms"][source] if source in o.get("algorithms", {}) else o["bayes"][source]


def replicate_params(raw: Mapping, replicate: int) -> dict:
    """The raw params mapping of a replicate: the same but every source's seed (:func:`replicate_seeds`)."""
    out = copy.deepcopy(dict(raw))
    for source, seed in replicate_seeds(raw, replicate).items():
        _seed_node(out["optimise"], source)["seed"] = seed
    return out


#: The params groups the chain's stages read (its pipeline's ``params``, the study's own ``robustness`` aside): the
#: groups that only other commands read (``benchmark``, ``epa``, ``bound``) do not move a replicate.
CHAIN_PARAMS: tuple[str, ...] = (
    "optimise",
    "surrogate",
    "screen",
    "validate",
    "design_space",
    "doe",
    "cycles",
    "baseline",
    "sim",
    "pms",
)


def fingerprint(raw: Mapping, code_hash: str, sim_fingerprint: str) -> str:
    """What a stored replicate depends on: every params group a stage of the chain reads (:data:`CHAIN_PARAMS`;
    where batches run aside), the simulator (``sim_fingerprint``) and the chain's code (``code_hash``)."""
    params = {k: v for k, v in raw.items() if k in CHAIN_PARAMS}
    sim = {k: v for k, v in params.get("sim", {}).items() if k not in ("executor", "scheduler", "workers")}
    blob = json.dumps(
        {
            **params,
            "sim": sim,
            "robustness_seed": raw.get("robustness", {}).get("seed"),
            "code": code_hash,
            "simulator": sim_fingerprint,
        },
        sort_keys=True,
        default=str,
    )
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def settings_fingerprint(params_path: str | Path) -> tuple[dict, str]:
    """The raw params mapping of ``params_path`` and the :func:`fingerprint` of a replicate run with it here (the
    chain's code: :data:`RUN_MODULES`' import closure in this checkout)."""
    root = Path(__file__).resolve().parents[1]
    raw = yaml.safe_load(Path(params_path).read_text())
    return raw, fingerprint(raw, chain_code_hash(root), simulation_fingerprint(load_params(params_path)))


#: Modules of the chain that only draw or word what a replicate's ``result.json`` does not hold (plots, the
#: explorer, ``summary.md``, this study's own summary) or keep books (the code-dependency lists): left out of
#: :func:`chain_code_hash`.
PRESENTATION = (
    "hevlib/plots/",
    "hevlib/explorer/",
    "hevlib/report.py",
    "hevlib/robustness.py",
    "hevlib/codedeps.py",
)


def chain_code_hash(root: Path) -> str:
    """Short hash of the code that computes a replicate's result: :data:`RUN_MODULES` with everything they import
    but :data:`PRESENTATION`, so that an edit to a plot, a page or a sentence does not run every replicate again."""
    root = Path(root)
    files = {p.relative_to(root).as_posix() for m in RUN_MODULES for p in import_closure(root, m).values()}
    return closure_hash(root, (), [f for f in files if not f.startswith(PRESENTATION)])


def collect(folder: Path, replicate: int, seeds: Mapping[str, int], fingerprint_: str) -> dict:
    """``result.json`` of a finished replicate: its seeds, the recommended design (variables, knee criteria,
    source, knee share), its near-equivalents, the answer's figures and each source's judged archive
    hypervolume."""
    folder = Path(folder)
    validation = from_json(ValidationSummary, json.loads((folder / "reports/validation.json").read_text()))
    answer = json.loads((folder / "reports/answer.json").read_text())
    pareto = json.loads((folder / "reports/pareto.json").read_text())
    rec = validation.recommendation
    d = rec.design
    head = rec.cycle

    def design(entry: Pick | Equivalent) -> dict:
        return {
            "design_id": entry.design_id,
            "algo": entry.algo,
            "design": {v: float(entry.design[v]) for v in DESIGN_VARS},
        }

    return {
        "replicate": int(replicate),
        "fingerprint": fingerprint_,
        "seeds": {k: int(v) for k, v in seeds.items()},
        "recommended": None
        if d is None
        else {
            **design(d),
            "criteria": {c: d.by_cycle[head]["design"][c] for c in KNEE_CRITERIA},
            "knee_share": rec.noise.knee_share.get(d.design_id) if rec.noise is not None else None,
        },
        "equivalents": [design(e) for e in rec.equivalents],
        "answer": {k: answer.get(k) for k in SPREAD_KEYS},
        "archive_hypervolume": {a: v.get("hypervolume") for a, v in pareto.get("sources", {}).items()},
    }


def _spread(values: Sequence[float | None]) -> dict:
    x = np.array([v for v in values if v is not None], dtype=float)
    if x.size == 0:
        return {"n": 0}
    return {
        "n": int(x.size),
        "replicate_0": values[0],
        "mean": float(x.mean()),
        "std": float(x.std(ddof=1)) if x.size > 1 else 0.0,
        "min": float(x.min()),
        "max": float(x.max()),
        "median": float(np.median(x)),
    }


def summarise(results: Sequence[Mapping], lower: np.ndarray, upper: np.ndarray) -> dict:
    """``reports/robustness/summary.json``: per replicate its seeds and answer; how often each recommended
    design and its family come out; whether each replicate's answer is the default one (replicate 0's design or
    one of its near-equivalents, to the family); the spread of the headline figures."""
    results = sorted(results, key=lambda r: r["replicate"])
    if not results or results[0]["replicate"] != 0:
        raise ValueError("robustness: replicate 0 (the params' own seeds) is missing")
    recs = [r["recommended"] for r in results]
    X = np.array([[np.nan] * len(DESIGN_VARS) if d is None else [d["design"][v] for v in DESIGN_VARS] for d in recs])
    n = len(results)

    def family_of(x) -> np.ndarray:
        return same_family(X, x, lower, upper) & np.all(np.isfinite(X), axis=1)

    default = results[0]
    designs = []
    for i, (r, d) in enumerate(zip(results, recs, strict=True)):
        if d is None:
            continue
        fam = family_of(X[i])
        exact = np.all(X == X[i], axis=1)
        as_default = _as_default(X[i], recs[0], default["equivalents"], lower, upper)
        designs.append(
            {
                "replicate": r["replicate"],
                **d,
                "same_design_replicates": [results[j]["replicate"] for j in np.flatnonzero(exact)],
                "family_replicates": [results[j]["replicate"] for j in np.flatnonzero(fam)],
                "family_share": float(fam.sum() / n),
                "default_answer": as_default is not None,
                "default_answer_as": as_default,
            }
        )
    modal = max(designs, key=lambda d: (len(d["family_replicates"]), -d["replicate"])) if designs else None
    sources = sorted({d["algo"] for d in designs})
    return {
        "replicates": n,
        "seeds_per_source": n,
        "family_share_of_range": FAMILY_SHARE,
        "criteria": list(KNEE_CRITERIA),
        "runs": [
            {
                "replicate": r["replicate"],
                "seeds": r["seeds"],
                "recommended": None if r["recommended"] is None else r["recommended"]["design_id"],
                "algo": None if r["recommended"] is None else r["recommended"]["algo"],
                "equivalents": [e["design_id"] for e in r["equivalents"]],
                "answer": r["answer"],
                "archive_hypervolume": r["archive_hypervolume"],
            }
            for r in results
        ],
        "recommended": designs,
        "default_answer_share": float(np.mean([d["default_answer"] for d in designs])) if designs else 0.0,
        "default_family_share": designs[0]["family_share"] if designs and designs[0]["replicate"] == 0 else 0.0,
        "modal_family": None
        if modal is None
        else {"replicate": modal["replicate"], "design_id": modal["design_id"], "share": modal["family_share"]},
        "recommended_by_source": {s: sum(d["algo"] == s for d in designs) for s in sources},
        "spread": {k: _spread([r["answer"].get(k) for r in results]) for k in SPREAD_KEYS},
        "variable_range": _variable_range(X, lower, upper),
        "criteria_spread": {c: _spread([None if d is None else d["criteria"][c] for d in recs]) for c in KNEE_CRITERIA},
        "archive_hypervolume_spread": {
            s: _spread([r["archive_hypervolume"].get(s) for r in results])
            for s in sorted({s for r in results for s in r["archive_hypervolume"]})
        },
    }


def _variable_range(X: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> dict:
    """Per variable, the range the replicates' recommended designs span, also as a share of the design box."""
    ok = np.all(np.isfinite(X), axis=1)
    out = {}
    for j, v in enumerate(DESIGN_VARS):
        col = X[ok, j]
        if col.size == 0:
            continue
        lo, hi = float(col.min()), float(col.max())
        out[v] = {"min": lo, "max": hi, "share_of_range": (hi - lo) / float(upper[j] - lower[j])}
    return out


def _as_default(x, rec0, equivalents, lower, upper) -> str | None:
    """How a replicate's recommended design ``x`` relates to the default answer: ``recommended`` (of its
    family), ``equivalent <id>`` (of a near-equivalent's family) or None."""
    if rec0 is None:
        return None
    if same_family(np.array([[rec0["design"][v] for v in DESIGN_VARS]]), x, lower, upper)[0]:
        return "recommended"
    for e in equivalents:
        if same_family(np.array([[e["design"][v] for v in DESIGN_VARS]]), x, lower, upper)[0]:
            return f"equivalent {e['design_id']}"
    return None


__all__ = [
    "RUN_MODULES",
    "PRESENTATION",
    "SEEDED_SOURCES",
    "SHARED_INPUTS",
    "SPREAD_KEYS",
    "chain_code_hash",
    "collect",
    "fingerprint",
    "replicate_params",
    "replicate_seed",
    "replicate_seeds",
    "settings_fingerprint",
    "summarise",
]
