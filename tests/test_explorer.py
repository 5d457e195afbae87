"""reports/explorer.html in a real headless Chromium, offline: it loads with nothing fetched, the table shows the
Parquet's numbers, dragging along an axis filters the table to exactly the designs in the brushed range, and
"copy as a designs CSV" gives a file `hev simulate --designs` reads back to the same designs."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from browser import chromium, wait_for

from hevlib.controller_gap import GAP_COLUMNS
from hevlib.design import DESIGN_VARS, OBJECTIVES, read_designs
from hevlib.explorer import explorer_data, explorer_html
from hevlib.io import read_table, write_table
from hevlib.validation import recommended_gap

N = 40


def _merged(path) -> pd.DataFrame:
    rng = np.random.default_rng(3)
    df = pd.DataFrame(
        {
            "design_id": [f"{'oracle' if i % 3 else 'nsga3'}-{i}" for i in range(N)],
            "algo": ["oracle" if i % 3 else "nsga3" for i in range(N)],
        }
    )
    for v in DESIGN_VARS:
        df[v] = np.round(rng.uniform(10, 60, N)) if v in ("n_bat", "n_r", "n_s") else rng.uniform(1, 70, N)
    for k in OBJECTIVES:
        df[f"sim_{k}"] = rng.uniform(0.5, 30.0, N)
    df["kept"] = np.arange(N) < 20
    df["picked"] = np.arange(N) < 5
    write_table(path, df)
    return read_table(path)


def _gap() -> dict:
    """The controller's gap of two picks and both cars on FTP (:func:`recommended_gap` of a hand-made table)."""
    fc = {
        "oracle-1": (4.5, 4.2, 4.0),
        "oracle-2": (4.8, 4.4, 4.1),
        "prius": (5.0, 4.6, 4.3),
        "conventional": (8.0, None, 7.8),
    }
    rows = [
        dict.fromkeys(GAP_COLUMNS, np.nan)
        | {
            "vehicle": v,
            "cycle": "ftp",
            "rule_fc_hot": r,
            "ecms_drive_fc_hot": np.nan if d is None else d,
            "bound_fc": b,
        }
        | {"note": ""}
        for v, (r, d, b) in fc.items()
    ]
    return recommended_gap(pd.DataFrame(rows, columns=list(GAP_COLUMNS)), ["oracle-1", "oracle-2"], "oracle-1")


GAP = _gap()


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("explorer")
    merged = _merged(tmp / "merged.parquet")
    base = {"prius": {v: 30.0 for v in (*DESIGN_VARS, *OBJECTIVES)}, "conventional": {k: 20.0 for k in OBJECTIVES}}
    html = explorer_html(explorer_data(merged, base, "oracle-1", "udds", equivalents=["oracle-2"], controller_gap=GAP))
    path = tmp / "explorer.html"
    path.write_text(html)
    driver = chromium()
    try:
        driver.get(path.as_uri())
        wait_for(driver, "window.hevExplorer && window.hevExplorer.ready")
        yield driver, merged, html, tmp
    finally:
        driver.quit()


def test_the_page_is_self_contained_and_fetches_nothing(page):
    driver, _, html, _ = page
    assert "<script src" not in html and "<link" not in html  # everything inlined
    fetched = driver.execute_script(
        "return performance.getEntriesByType('resource').map(e => e.name).filter(n => !n.startsWith('file:'))"
    )
    assert fetched == []
    assert driver.execute_script("return typeof Plotly.version") == "string"
    assert driver.execute_script("return document.querySelectorAll('.parcoords .axis-brush').length") == 18


def _table(driver) -> pd.DataFrame:
    head = driver.execute_script("return [...document.querySelectorAll('#designs thead th')].map(c => c.textContent)")
    body = driver.execute_script(
        "return [...document.querySelectorAll('#designs tbody tr')].map(r => [...r.children].map(c => c.textContent))"
    )
    return pd.DataFrame(body, columns=head)


def test_the_table_shows_the_parquets_numbers(page):
    driver, merged, _, _ = page
    shown = _table(driver).set_index("design")
    assert len(shown) == N
    for _, row in merged.iterrows():
        cells = shown.loc[row["design_id"]]
        for v in DESIGN_VARS:
            got = float(cells[next(c for c in shown.columns if c.split(" ")[0] == v)])
            assert got == pytest.approx(row[v], rel=1e-5)
        for k in OBJECTIVES:
            got = float(cells[next(c for c in shown.columns if c.split(" ")[0] == k)])
            assert got == pytest.approx(row[f"sim_{k}"], rel=1e-5)


def test_the_recommended_design_and_its_near_equivalents_are_marked(page):
    driver, _, html, _ = page
    status = _table(driver).set_index("design")["status"]
    assert status["oracle-1"] == "recommended" and status["oracle-2"] == "near-equivalent"
    assert status["nsga3-0"] == "picked" and "near-equivalents within the model's noise (oracle-2)" in html
    names = driver.execute_script("return document.getElementById('scatter').data.map(t => t.name)")
    assert "near-equivalents" in names and "recommended" in names


def test_the_controller_gap_table_shows_each_vehicle_under_each_controller(page):
    driver, _, html, _ = page
    head = driver.execute_script("return [...document.querySelectorAll('#gap thead th')].map(c => c.textContent)")
    assert head[:6] == [
        "cycle",
        "vehicle",
        "rule [L/100 km]",
        "ecms_drive [L/100 km]",
        "ecms [L/100 km]",
        "bound [L/100 km]",
    ]
    body = driver.execute_script(
        "return [...document.querySelectorAll('#gap tbody tr')].map(r => [...r.children].map(c => c.textContent))"
    )
    shown = {r[1]: r for r in body}
    assert list(shown) == ["oracle-1 (recommended)", "oracle-2", "prius", "conventional"]
    assert shown["oracle-2"][2:6] == ["4.8", "4.4", "n/a", "4.1"] and shown["conventional"][3] == "n/a"
    assert shown["oracle-1 (recommended)"][6] == "+12.5 %"  # the rule base over the bound: 4.5 / 4.0
    intro = driver.execute_script("return document.getElementById('gap-intro').textContent")
    assert "ftp: rule 43.8 %" in intro and "bound 50.0 %" in intro and "bound_both 48.7 %" in intro
    assert driver.execute_script("return getComputedStyle(document.getElementById('gap-section')).display") == "block"


def test_dragging_an_axis_filters_the_table_to_the_brushed_range_and_copies_a_designs_csv(page):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    driver, merged, _, tmp = page
    j = len(DESIGN_VARS) + OBJECTIVES.index("fc")
    axis = driver.find_elements(By.CSS_SELECTOR, ".parcoords .axis-brush .background")[j]
    h = axis.rect["height"]
    ActionChains(driver).move_to_element_with_offset(axis, 0, -0.45 * h).click_and_hold().move_by_offset(
        0, 0.5 * h
    ).release().perform()
    wait_for(driver, f"document.getElementById('parcoords').data[0].dimensions[{j}].constraintrange")
    lo, hi = np.ravel(
        driver.execute_script(f"return document.getElementById('parcoords').data[0].dimensions[{j}].constraintrange")
    )[:2]
    fc = merged["sim_fc"].to_numpy()
    expected = sorted(merged["design_id"][(fc >= lo) & (fc <= hi)])
    assert 0 < len(expected) < N  # the drag brushed part of the axis
    wait_for(driver, f"document.querySelectorAll('#designs tbody tr').length === {len(expected)}")
    assert sorted(_table(driver)["design"]) == expected
    assert driver.find_element(By.ID, "count").text == f"{len(expected)} of {N} designs"

    driver.find_element(By.ID, "copy").click()
    csv = tmp / "brushed.csv"
    csv.write_text(driver.find_element(By.ID, "csv").get_property("value"))
    X = read_designs(csv)  # what `hev simulate --designs` reads
    ids = pd.read_csv(csv)["design_id"].tolist()
    assert sorted(ids) == expected
    want = merged.set_index("design_id").loc[ids, list(DESIGN_VARS)].to_numpy()
    np.testing.assert_array_equal(X, want)  # the same floats, not rounded


def test_dvc_plots_show_draws_its_charts_offline(tmp_path):
    """`.dvc/config` points `dvc plots show` at vendor/dvc_plots_offline.html (ci/vendor_vega.sh: Vega,
    Vega-Lite and Vega-Embed inlined), so the trade-off charts draw with no network."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    repo = Path(__file__).resolve().parents[1]
    dvc = Path(sys.executable).parent / "dvc"
    out = subprocess.run(
        [str(dvc), "plots", "show", "fc_vs_diff_soc", "m_veh_vs_speed_dev", "-o", str(tmp_path / "plots")],
        cwd=repo,
        env={**os.environ, "DVC_NO_ANALYTICS": "1"},
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr
    page = (tmp_path / "plots" / "index.html").read_text()
    assert "cdn.jsdelivr" not in page and "<script src" not in page
    assert "oracle.csv" in page and "share of the cycle off the trace" in page
    driver = chromium(1200, 900)
    try:
        driver.get((tmp_path / "plots" / "index.html").as_uri())
        drawn = "[...document.querySelectorAll('.vega-embed')].filter(e => e.querySelector('svg, canvas')).length"
        # both charts: wait for the count itself (a truthy 1 while the second chart still renders is not done)
        assert wait_for(driver, f"({drawn}) >= 2") and driver.execute_script(f"return {drawn}") == 2
        fetched = driver.execute_script(
            "return performance.getEntriesByType('resource').map(e => e.name).filter(n => !n.startsWith('file:'))"
        )
        assert fetched == []
    finally:
        driver.quit()
