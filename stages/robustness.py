"""``hev robustness run`` and ``hev robustness report``: how stable the answer is across seeds (its own pipeline,
``benchmarks/robustness/dvc.yaml``; not part of the default ``dvc repro``).

``run`` reruns the optimise -> pareto -> validate chain for every replicate (``robustness.seeds``; replicate 0
keeps the params' seeds) in ``data/robustness/runs/rep_<k>/`` with the ``hev`` stage commands themselves; a
replicate already on disk with the same settings and code is kept (``--fresh`` runs it again). ``report`` writes
``reports/robustness/summary.json`` and ``seed_spread.png`` (:mod:`hevlib.robustness`)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import typer
import yaml

from hevlib.io import write_json, write_text
from hevlib.robustness import (
    SHARED_INPUTS,
    collect,
    replicate_params,
    replicate_seeds,
    settings_fingerprint,
    summarise,
)
from stages.cli import app
from stages.common import PARAMS_OPTION, params_from, stage

RUNS_DIR = Path("data/robustness/runs")
#: The report stage's declared output (DVC) and the committed copy the default pipeline's validate stage reads
#: (a path no stage declares, so that the default `dvc repro` never pulls the robustness study in).
SUMMARY = Path("data/robustness/summary.json")
REPORT_DIR = Path("reports/robustness")
REPORT = REPORT_DIR / "summary.json"


def _prepare(folder: Path, raw: dict, replicate: int) -> None:
    """A fresh replicate folder: its params.yaml and links to the shared inputs."""
    for rel in SHARED_INPUTS:
        if not Path(rel).exists():
            raise FileNotFoundError(f"{rel}: no such input; run `dvc repro` first")
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    write_text(folder / "params.yaml", yaml.safe_dump(replicate_params(raw, replicate), sort_keys=False))
    for rel in SHARED_INPUTS:
        link = folder / rel
        link.parent.mkdir(parents=True, exist_ok=True)
        link.symlink_to(os.path.relpath(Path(rel).resolve(), link.parent.resolve()))


def _chain(sources: list[str]) -> list[list[str]]:
    """The ``hev`` commands of a replicate, in order (the oracle first: the others report against it)."""
    # the chain's code, imported so that it is this command's (and its DVC stage's) code dependency
    import stages.optimise  # noqa: F401
    import stages.pareto  # noqa: F401
    import stages.validate  # noqa: F401

    first = ["oracle"] if "oracle" in sources else []
    return [
        *(["optimise", s] for s in first + [s for s in sources if s != "oracle"]),
        ["pareto"],
        ["validate", "--no-gap"],
    ]


@app.command("robustness")
@stage
def robustness(
    action: str = typer.Argument(..., help="run (every replicate's chain) or report (the seed spread)"),
    params: str = PARAMS_OPTION,
    fresh: bool = typer.Option(False, "--fresh", help="run: every replicate again, even those on disk"),
) -> None:
    """Rerun the optimise -> pareto -> validate chain with other seeds of every source (``run``), or summarise
    how often each recommended design and its family come out, with the headline's seed spread (``report``)."""
    if action not in ("run", "report"):
        raise ValueError(f"robustness: unknown action {action!r} (use run or report)")
    cfg = params_from(params)
    if cfg.optimise is None:
        raise ValueError("params.yaml: optimise: group missing (the robustness study reruns the optimisers)")
    raw, fp = settings_fingerprint(params)
    n = cfg.robustness.seeds
    if action == "report":
        _report(cfg, fp, n)
        return
    for k in range(n):
        folder = RUNS_DIR / f"rep_{k}"
        result = folder / "result.json"
        if not fresh and result.exists() and json.loads(result.read_text()).get("fingerprint") == fp:
            typer.echo(f"robustness: replicate {k} on disk is current")
            continue
        _prepare(folder, raw, k)
        t0 = time.perf_counter()
        for cmd in _chain(list(cfg.optimise.sources)):
            out = subprocess.run(
                [sys.executable, "-m", "stages.cli", *cmd, "--params", "params.yaml"],
                cwd=folder,
                capture_output=True,
                text=True,
            )
            log = folder / "logs" / f"{'_'.join(cmd)}.log"
            log.parent.mkdir(parents=True, exist_ok=True)
            log.write_text(out.stdout + out.stderr)
            if out.returncode != 0:
                tail = (out.stderr.strip() or out.stdout.strip()).splitlines()[-1:] or ["failed"]
                raise ValueError(f"robustness: replicate {k}: hev {' '.join(cmd)}: {tail[0]} (log: {log})")
        write_json(result, collect(folder, k, replicate_seeds(raw, k), fp))
        rec = json.loads(result.read_text())["recommended"]
        typer.echo(
            f"robustness: replicate {k} in {time.perf_counter() - t0:.0f} s: recommended "
            f"{rec['design_id'] if rec else 'none'} -> {result}"
        )


def _report(cfg, fp: str, n: int) -> None:
    from hevlib.plots import save_figure  # matplotlib: only the report draws
    from hevlib.plots.robustness import seed_spread_figure

    results = []
    for k in range(n):
        path = RUNS_DIR / f"rep_{k}" / "result.json"
        if not path.exists():
            raise FileNotFoundError(f"{path}: no such replicate; run `hev robustness run` first")
        r = json.loads(path.read_text())
        if r.get("fingerprint") != fp:
            raise ValueError(f"{path}: made with other settings or code; run `hev robustness run` again")
        # read again from the replicate's reports, so that a change to what is collected needs no rerun
        results.append(collect(path.parent, k, r["seeds"], fp))
    space = cfg.design_space.space()
    summary = {"fingerprint": fp, "seed": cfg.robustness.seed, **summarise(results, space.lower, space.upper)}
    write_json(SUMMARY, summary)
    write_json(REPORT, summary)
    save_figure(seed_spread_figure(summary, space.lower, space.upper), REPORT_DIR / "seed_spread.png")
    s = summary["spread"]["rec_fc_cb_pct"]
    typer.echo(
        f"robustness: {n} seeds per source; the default answer (to the family, or a near-equivalent) in "
        f"{100 * summary['default_answer_share']:.0f} % of the replicates; rec_fc_cb_pct {s['mean']:.1f} "
        f"(min {s['min']:.1f}, max {s['max']:.1f}) -> {REPORT_DIR / 'summary.json'}, {REPORT_DIR / 'seed_spread.png'}"
    )
