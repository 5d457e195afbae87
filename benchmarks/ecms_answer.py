"""The answer under ECMS (issue 56): does the recommended car change when the designs are judged with ECMS in the
drive step (``pms.strategy: ecms``) instead of the study's rule base?

The whole pipeline under ECMS (``dvc exp run -S pms.strategy=ecms``) reruns every search with ECMS in the loop, and on
two cores that is out of reach: ECMS costs about 50x the rule base per design-cycle, so the judged scale's 10 000
designs alone take over an hour and the oracle's 100 200 simulations about half a day (this script prints the rate
it measured). What it does instead keeps every step after the searches: the last front of every source of
``optimise.sources`` (``data/pareto/<source>.parquet``, the designs the pipeline merges) is simulated again on the
sizing cycle under ECMS, and the pipeline's own ``hev pareto`` (merge, screen, keep, shortlist) and ``hev validate``
(FTP, HWFET and US06 under ECMS, charge-balanced; the twins; the recommendation) run on it in a scratch folder with
the same params but ``pms.strategy: ecms``. What it cannot say: which designs a search would find with ECMS in its
loop (the fronts are the rule base's searches'). The per-source judging of that ``hev pareto`` run reads the sources'
archives, which stay the rule base's: it is not read here.

It writes ``reports/ecms_answer.json`` (both answers side by side: the recommended design, its variables, its
family, its charge-balanced fuel saving on the headline cycle, the shortlists and their overlap) and prints the
table docs/controller.md quotes. From the repository root, after ``dvc repro``:

    python benchmarks/ecms_answer.py [--scratch DIR] [--keep]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# isort: off
import hevlib  # noqa: F401  (before numpy: pins its CPU-dependent code paths)
import numpy as np
import pandas as pd
import yaml
# isort: on

from hevlib.design import DESIGN_VARS, RESPONSES
from hevlib.io import write_json, write_parquet
from hevlib.optimise.resim import resimulate
from hevlib.params import load_params, parse_params
from hevlib.pareto import table_schema
from hevlib.recommend import FAMILY_SHARE, same_family
from hevlib.sim.simulator import Simulator

ROOT = Path(__file__).resolve().parents[1]
#: What the scratch folder shares with the default pipeline (linked, never written).
LINKED = ("data/cycles", "data/components", "data/judge", "data/doe")
#: Reports the scratch ``hev pareto`` and ``hev validate`` read (copied).
COPIED = ("reports/surrogate_metrics.json",)


def ecms_raw(params_path: Path) -> dict:
    raw = yaml.safe_load(params_path.read_text())
    raw["pms"]["strategy"] = "ecms"
    return raw


def resimulated_fronts(sources: list[str], params, components: Path, scratch: Path) -> tuple[int, float]:
    """Every source's last front simulated again on the sizing cycle under ``params`` (ECMS), written into the
    scratch folder's ``data/pareto/<source>.parquet``; its archive linked."""
    from hevlib.cycles import Cycle

    name = params.cycles.sizing
    cycle = Cycle.from_parquet(ROOT / "data/cycles" / f"{name}.parquet", name)  # its grade attached
    n, t0 = 0, time.perf_counter()
    with Simulator.from_params(params, components_dir=str(components)) as sim:
        simulate = sim.on_cycle(cycle, params.doe.batch_size)
        for s in sources:
            table = pd.read_parquet(ROOT / "data/pareto" / f"{s}.parquet")
            last = table[table["round"] == table["round"].max()].reset_index(drop=True)
            r = resimulate(last[list(DESIGN_VARS)].to_numpy(dtype=float), simulate)
            for k in RESPONSES:
                last[f"sim_{k}"] = r[k].to_numpy(dtype=last[f"sim_{k}"].dtype)
            # the rule base's dominance flag out: the pareto stage recomputes dominance over the merged fronts
            # (hevlib.pareto.FRONT_FLAGS)
            last = last.drop(columns=["nondominated_sim"])
            write_parquet(scratch / "data/pareto" / f"{s}.parquet", last, table_schema(last))
            link = scratch / "data/pareto" / f"{s}_archive.parquet"
            link.symlink_to(ROOT / "data/pareto" / f"{s}_archive.parquet")
            shutil.copy(ROOT / "reports" / f"optimise_{s}.json", scratch / "reports" / f"optimise_{s}.json")
            n += len(last)
            print(f"ecms_answer: {s}: {len(last)} designs under ECMS ({time.perf_counter() - t0:.0f} s so far)")
    return n, time.perf_counter() - t0


def run_stage(scratch: Path, *cmd: str) -> None:
    out = subprocess.run(
        [sys.executable, "-m", "stages.cli", *cmd, "--params", "params.yaml"],
        cwd=scratch,
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    (scratch / "logs").mkdir(exist_ok=True)
    (scratch / "logs" / f"{'_'.join(cmd)}.log").write_text(out.stdout + out.stderr)
    if out.returncode != 0:
        raise SystemExit(f"ecms_answer: hev {' '.join(cmd)} failed:\n{out.stderr[-2000:] or out.stdout[-2000:]}")
    print(out.stdout.strip().splitlines()[-1] if out.stdout.strip() else f"hev {' '.join(cmd)}: done")


def answer_of(folder: Path) -> dict:
    """One answer: the recommended design, its variables and kind, its saving, the shortlist."""
    v = json.loads((folder / "reports/validation.json").read_text())
    head = json.loads((folder / "reports/headline.json").read_text())
    rec = v["recommendation"]["design"]
    shortlist = pd.read_parquet(folder / "data/pareto/selected.parquet")["design_id"].astype(str).tolist()
    return {
        "recommended": rec["design_id"] if rec else None,
        "design": rec["design"] if rec else None,
        "equivalents": [e["design_id"] for e in v["recommendation"].get("equivalents", [])],
        "recommended_fc_saving_charge_balanced_pct": head["recommended_fc_saving_charge_balanced_pct"],
        "fc_saving_charge_balanced_pct": head["fc_saving_charge_balanced_pct"],
        "by_cycle": {c: f["design"] for c, f in rec["by_cycle"].items()} if rec else None,
        "shortlist": shortlist,
    }


def crossed(raw: dict, designs: dict[str, dict], cycle_name: str) -> dict:
    """Each recommended design under each controller on the headline cycle, charge-balanced (SAE J1711): whether
    ECMS's pick wins under the rule base too (the searches missed it) or only under ECMS (the hardware suits it)."""
    from hevlib.cycles import Cycle

    cycle = Cycle.from_parquet(ROOT / "data/cycles" / f"{cycle_name}.parquet", cycle_name)
    X = np.array([[d[v] for v in DESIGN_VARS] for d in designs.values()], dtype=float)
    out = {}
    for strategy in ("fuzzy", "ecms"):
        p = parse_params({**raw, "pms": {**raw["pms"], "strategy": strategy}})
        with Simulator.from_params(p, components_dir=str(ROOT / "data/components")) as sim:
            r = sim.run(X, cycle, charge_balanced=True)
            conv = float(sim.run(None, cycle, "conventional")["fc"].iloc[0])
        out[strategy] = {
            label: {
                "fc_charge_balanced": float(r["fc_charge_balanced"].iloc[i]),
                "saving_vs_conventional_pct": 100.0 * (1.0 - float(r["fc_charge_balanced"].iloc[i]) / conv),
                "cycle_met": bool(r["cycle_met"].iloc[i]),
            }
            for i, label in enumerate(designs)
        }
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scratch", type=Path, default=None, help="scratch folder (default: a temporary one)")
    ap.add_argument("--keep", action="store_true", help="keep the scratch folder")
    ap.add_argument("--out", type=Path, default=ROOT / "reports/ecms_answer.json")
    a = ap.parse_args()
    scratch = a.scratch or Path(tempfile.mkdtemp(prefix="ecms_answer_"))
    if scratch.exists():
        shutil.rmtree(scratch)
    (scratch / "data/pareto").mkdir(parents=True)
    (scratch / "reports").mkdir()
    raw = ecms_raw(ROOT / "params.yaml")
    (scratch / "params.yaml").write_text(yaml.safe_dump(raw, sort_keys=False))
    for rel in LINKED:
        (scratch / rel).symlink_to(ROOT / rel)
    for rel in COPIED:
        shutil.copy(ROOT / rel, scratch / rel)
    params = load_params(scratch / "params.yaml")
    sources = list(params.optimise.sources)
    n, wall = resimulated_fronts(sources, params, ROOT / "data/components", scratch)
    t0 = time.perf_counter()
    run_stage(scratch, "pareto")
    run_stage(scratch, "validate", "--no-gap")
    validate_s = time.perf_counter() - t0

    rule, ecms = answer_of(ROOT), answer_of(scratch)
    space = params.design_space.space()

    def x(answer: dict) -> np.ndarray:
        return np.array([answer["design"][v] for v in DESIGN_VARS], dtype=float)

    same_kind = (
        rule["design"] is not None
        and ecms["design"] is not None
        and bool(same_family(x(ecms), x(rule), space.lower, space.upper)[0])
    )
    # per variable, how far apart the two recommended designs are, as a share of its range
    apart = (
        {
            v: abs(rule["design"][v] - ecms["design"][v]) / (hi - lo)
            for v, lo, hi in zip(DESIGN_VARS, space.lower, space.upper, strict=True)
        }
        if rule["design"] and ecms["design"]
        else None
    )
    report = {
        "what": "the answer with the designs judged under ECMS in the drive step (pms.strategy: ecms) against the "
        "rule base's, on the last fronts of every source (the searches are the rule base's): benchmarks/ecms_answer.py",
        "sources": sources,
        "designs_resimulated": n,
        "resimulation_wall_s": wall,
        "design_cycles_per_s_under_ecms": n / wall,
        "pareto_and_validate_wall_s": validate_s,
        "rule": rule,
        "ecms": ecms,
        "same_recommended": rule["recommended"] == ecms["recommended"],
        "same_family": bool(same_kind),
        "family_share_of_range": FAMILY_SHARE,
        "apart_share_of_range": apart,
        "shortlist_overlap": sorted(set(rule["shortlist"]) & set(ecms["shortlist"])),
        "rule_recommended_in_ecms_shortlist": rule["recommended"] in ecms["shortlist"],
    }
    headline = next(iter(rule["by_cycle"]))
    if rule["design"] and ecms["design"]:
        picks = {
            f"rule base's pick {rule['recommended']}": rule["design"],
            f"ECMS's pick {ecms['recommended']}": ecms["design"],
        }
        report["crossed"] = {"cycle": headline, **crossed(raw, picks, headline)}
    write_json(a.out, report)
    print("\n| | rule base | ECMS in the drive step |\n|---|---|---|")
    print(f"| recommended | {rule['recommended']} | {ecms['recommended']} |")
    for k in DESIGN_VARS:
        print(f"| {k} | {rule['design'][k]:.4g} | {ecms['design'][k]:.4g} |")
    print(
        f"| saving vs conventional, charge-balanced, {next(iter(rule['by_cycle']))} | "
        f"{rule['recommended_fc_saving_charge_balanced_pct']:.1f} % | "
        f"{ecms['recommended_fc_saving_charge_balanced_pct']:.1f} % |"
    )
    for strategy, by in report.get("crossed", {}).items():
        if strategy != "cycle":
            print(
                f"under {strategy} on {headline}: "
                + "; ".join(
                    f"{k} {v['fc_charge_balanced']:.3f} L/100 km ({v['saving_vs_conventional_pct']:.1f} %)"
                    for k, v in by.items()
                )
            )
    print(
        f"\nshortlists overlap {len(report['shortlist_overlap'])} of {len(rule['shortlist'])}; same recommended: "
        f"{report['same_recommended']}; same family (every variable within {FAMILY_SHARE:.0%} of its range): "
        f"{report['same_family']}; "
        f"{n} designs under ECMS at {n / wall:.2f} design-cycles/s -> wrote {a.out}"
    )
    if not a.keep and a.scratch is None:
        shutil.rmtree(scratch)


if __name__ == "__main__":
    main()
