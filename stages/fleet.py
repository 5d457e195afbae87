"""``hev fleet cases|simulate|report``: the simulator against EPA's dynamometer tests of real cars (issue 52; its
own pipeline, ``benchmarks/fleet/dvc.yaml``, outside the default ``dvc repro``; :mod:`hevlib.fleet`).

``cases`` selects the FTP, HWFET and US06 tests of two-wheel-drive conventional gasoline cars and power-split
hybrids from the project's copy of the list and lists every other such test with its reason; ``simulate`` drives
each on the simulator from the row's own figures; ``report`` compares them, and FASTSim 2.1.5's predictions of the
same tests (``benchmarks/fleet/fastsim``), with what EPA measured."""

from __future__ import annotations

import json
import time
from pathlib import Path

import typer
import yaml

from hevlib.io import write_json, write_text
from stages.cli import app
from stages.common import PARAMS_OPTION, params_from, progress_callback, stage

TABLE = Path("data/raw/epa/test_car_list_2022.csv")
DATA_DIR = Path("data/fleet")
CASES = DATA_DIR / "cases.csv"
PREDICTED = DATA_DIR / "predicted.csv"
FASTSIM = DATA_DIR / "fastsim.csv"
REPORT_DIR = Path("reports/fleet")


def _write_csv(frame, path: Path) -> None:
    write_text(path, frame.to_csv(index=False, float_format="%.10g", lineterminator="\n"))


@app.command("fleet")
@stage
def fleet(
    action: str = typer.Argument(..., help="cases (select the tests), simulate (drive them) or report"),
    params: str = PARAMS_OPTION,
    jobs: int = typer.Option(2, "--jobs", min=1, help="simulate: processes that share the cars (same result)"),
) -> None:
    """The fleet validation: select EPA's tests of real cars (``cases``), simulate each from the row's own figures
    (``simulate``), and report predicted against measured fuel economy beside FASTSim 2.1.5 (``report``)."""
    import pandas as pd

    from hevlib import fleet as fl

    if action not in ("cases", "simulate", "report"):
        raise ValueError(f"fleet: unknown action {action!r} (use cases, simulate or report)")
    params_from(params)  # the params file validates before anything runs
    if action == "cases":
        sel = fl.select_tests(fl.read_tests(TABLE))
        _write_csv(sel.cases, CASES)
        _write_csv(sel.excluded, REPORT_DIR / "excluded.csv")
        n = sel.cases["powertrain"].value_counts()
        typer.echo(
            f"fleet: {len(sel.cases)} tests ({n.get('conventional', 0)} conventional, {n.get('power_split', 0)} "
            f"power-split), {len(sel.excluded)} left out -> {CASES}"
        )
        return
    if action == "simulate":
        from hevlib.cycles import build_cycles

        raw = yaml.safe_load(Path(params).read_text())
        cases = pd.read_csv(CASES, dtype={**fl.epa.COLUMNS, **fl.MEASURED}, keep_default_na=False, na_values=[""])
        t0 = time.perf_counter()
        with progress_callback("fleet: simulating") as progress:
            predicted = fl.predict_cases(raw, cases, build_cycles(params_from(params).cycles), progress, jobs)
        _write_csv(predicted, PREDICTED)
        ok = int((predicted["status"] == "ok").sum())
        typer.echo(
            f"fleet: {ok} of {len(predicted)} tests simulated in {time.perf_counter() - t0:.0f} s -> {PREDICTED}"
        )
        return
    _report(pd, fl)


def _report(pd, fl) -> None:
    from hevlib.plots import save_figure
    from hevlib.plots.fleet import predicted_vs_measured_figure

    cases = pd.read_csv(CASES, dtype={**fl.epa.COLUMNS, **fl.MEASURED}, keep_default_na=False, na_values=[""])
    predicted = pd.read_csv(PREDICTED, keep_default_na=False, na_values=[""])
    fastsim = pd.read_csv(FASTSIM, keep_default_na=False, na_values=[""]) if FASTSIM.exists() else None
    results = fl.results_table(cases, predicted, fastsim)
    excluded = pd.read_csv(REPORT_DIR / "excluded.csv")
    summary = fl.summarise(results, excluded)
    _write_csv(results, REPORT_DIR / "tests.csv")
    write_json(REPORT_DIR / "summary.json", summary)
    write_text(REPORT_DIR / "summary.md", fl.summary_markdown(summary))
    peers = {"predicted_mpg": "hev-sizing (this simulator)"}
    if fastsim is not None:
        peers["fastsim_mpg"] = "FASTSim 2.1.5"
    same = results[results[list(peers)].notna().all(axis=1)]  # the tests every predictor drove
    save_figure(predicted_vs_measured_figure(same, peers), REPORT_DIR / "predicted_vs_measured.png")
    typer.echo(f"fleet: report -> {REPORT_DIR}/summary.md ({json.dumps(summary['headline'])})")
