"""The pareto stage on the default pipeline's final fronts gives the tables the pandas implementation gave.

``tests/data/pareto_reference`` holds each source's final front and the merged and selected tables the
stage made of them, written by ``ci/pareto_reference.py`` at 5d4e005 (before the tables moved to polars
and dominance to moocore); ``summary.json`` is that run's ``reports/pareto.json`` less its hypervolumes.
Today's stage, with that run's pick (``random``, the study's; the default is now ``recommend``), must reproduce
both tables column for column and bit for bit, and the summary exactly -- less what was added since and is not
the reference's: the highway rule (``pass_min_v_max``, the ``min_v_max`` screening entry: off, so it removes
nothing), ``pick_role`` and the selection's ``pick_rule`` and ``roles``.
"""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq
import pytest

from hevlib.io import _jsonable, to_arrow
from hevlib.params import load_params
from hevlib.pareto import select_designs, table_schema
from hevlib.results import to_json
from hevlib.tables import scan

REPO = Path(__file__).resolve().parents[1]
REF = REPO / "tests" / "data" / "pareto_reference"
SOURCES = ("nsga3", "moead", "moga", "oracle")


@pytest.fixture(scope="module")
def result():
    params = load_params(REPO / "params.yaml")
    fronts = {a: scan(REF / "fronts" / f"{a}.parquet").drop("round") for a in SOURCES}
    return select_designs(fronts, params.screen.model_copy(update={"pick": "random"}))


#: Columns and summary entries added after the reference was written (module docstring).
ADDED_COLUMNS = ("pass_min_v_max", "pick_role")


@pytest.mark.parametrize("name", ["merged", "selected"])
def test_polars_tables_equal_the_pandas_ones(result, name):
    table = getattr(result, name)
    table = table.drop([c for c in ADDED_COLUMNS if c in table.columns])
    expected = pq.read_table(REF / f"{name}.parquet")
    got = to_arrow(table, table_schema(table))
    assert got.schema.equals(expected.schema.remove_metadata())
    pd.testing.assert_frame_equal(got.to_pandas(), expected.to_pandas(), check_exact=True)


def test_summary_equals_the_pandas_one(result):
    """Counts, screening report, per-algorithm counts and shares of reports/pareto.json as the pandas
    implementation wrote them (the hypervolume entries are not the stage's tables: see test_indicators)."""
    expected = json.loads((REF / "summary.json").read_text())
    summary = to_json(result.summary)
    got = json.loads(json.dumps(_jsonable({k: summary[k] for k in expected})))
    assert got["screen"].pop("min_v_max")["removed_in_sequence"] == 0
    assert got["selection"].pop("roles") == {} and got["selection"].pop("pick_rule")
    assert got == expected
    c = got["counts"]
    assert (
        c["input"] == 800
        and c["merged"] == 740
        and c["picked"] == 15
        and 0 < c["feasible"] <= c["nondominated"] < c["merged"]
    )
