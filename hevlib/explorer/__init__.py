"""``reports/explorer.html``: an offline explorer of the merged front (written by the validate stage).

One self-contained page: Plotly's own bundle (``plotly.min.js`` from the pinned ``plotly`` package, inlined
so that nothing is fetched), the data as JSON and a small script (``app.js``) that wires parallel
coordinates over the seven variables and eleven objectives (brushing an axis filters the table), a scatter
of any two axes (every source's front, the picks, the recommended design and both baselines) and a table of
the brushed designs with "copy as a designs CSV" in the column layout ``hev simulate --designs`` reads; below it,
the controller's gap of the shortlist and both reference cars (``validation.json``'s ``controller_gap``): each one's
fuel under the rule base, ECMS and the bound on every bound cycle, and the recommended design's saving under each.

Every number is the merged table's own float (``data/pareto/merged.parquet``, sizing cycle, simulated), written
with Python's shortest round-trip repr; the table shows six significant digits.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from importlib import resources
from pathlib import Path

import pandas as pd

from hevlib.design import DESIGN_VARS, OBJECTIVES, SENSE, UNITS
from hevlib.io import finite_or_none, write_text
from hevlib.pareto import algo_names
from hevlib.screen import SIM

_HERE = resources.files(__name__)


def plotly_bundle() -> str:
    """The minified Plotly.js that the pinned ``plotly`` Python package ships (its ``package_data``)."""
    return resources.files("plotly").joinpath("package_data/plotly.min.js").read_text(encoding="utf-8")


def explorer_data(
    merged: pd.DataFrame,
    baselines: dict[str, dict[str, float]],
    recommended: str | None,
    sizing_cycle: str,
    equivalents: Sequence[str] = (),
    controller_gap: Mapping | None = None,
) -> dict:
    """The page's data: axes (variables, then objectives, with units and sense), one row per merged design
    (its sources, kept/picked/equivalent/recommended flags and the values), and both baselines on the sizing
    cycle. ``equivalents``: the recommendation's near-equivalents (``recommendation.equivalents``);
    ``controller_gap``: :func:`hevlib.validation.gap.recommended_gap`'s figures (None: the page has no gap table)."""
    equivalent = set(map(str, equivalents))
    axes = [{"name": v, "unit": UNITS[v], "kind": "variable", "sense": None} for v in DESIGN_VARS]
    axes += [
        {"name": k, "unit": UNITS[k], "kind": "objective", "sense": "max" if s < 0 else "min"}
        for k, s in zip(OBJECTIVES, SENSE, strict=True)
    ]
    cols = [*DESIGN_VARS, *[f"{SIM}{k}" for k in OBJECTIVES]]
    values = merged[cols].to_numpy(dtype=float)
    rows = []
    for i, (_, r) in enumerate(merged.iterrows()):
        rows.append(
            {
                "id": str(r["design_id"]),
                "sources": algo_names(str(r["algo"])),
                "kept": bool(r.get("kept", False)),
                "picked": bool(r.get("picked", False)),
                "recommended": str(r["design_id"]) == recommended,
                "equivalent": str(r["design_id"]) in equivalent,
                "values": [finite_or_none(v) for v in values[i]],
            }
        )
    sources = list(dict.fromkeys(s for r in rows for s in r["sources"]))
    base = [
        {"id": name, "baseline": True, "values": [finite_or_none(b.get(a["name"], float("nan"))) for a in axes]}
        for name, b in baselines.items()
    ]
    return {
        "sizing_cycle": sizing_cycle,
        "axes": axes,
        "design_vars": list(DESIGN_VARS),
        "sources": sources,
        "rows": rows,
        "baselines": base,
        "recommended": recommended,
        "equivalents": [str(e) for e in equivalents],
        "default_x": "m_veh",
        "default_y": "fc",
        "gap": _clean(controller_gap) if controller_gap else None,
    }


def _clean(value):
    """``value`` with every non-finite float as None (the page's JSON has no NaN)."""
    if isinstance(value, Mapping):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(v) for v in value]
    if isinstance(value, float):
        return finite_or_none(value)
    return value


def explorer_html(data: dict) -> str:
    """The whole page: the template with Plotly, the data and the script inlined (no external reference)."""
    template = _HERE.joinpath("template.html").read_text(encoding="utf-8")
    payload = json.dumps(data, allow_nan=False, separators=(",", ":")).replace("</", "<\\/")
    intro = (
        f"{len(data['rows'])} designs from the fronts of {', '.join(data['sources'])}, simulated on the sizing cycle "
        f"({data['sizing_cycle']}); colours in the parallel coordinates: grey front, blue kept, orange picked, "
        f"red recommended ({data['recommended'] or 'none'}), purple its near-equivalents within the model's noise "
        f"({', '.join(data['equivalents']) or 'none'}), green the stock Prius. The conventional car has no "
        "hybrid variables and appears in the scatter only."
        + (
            " Below the table: the controller's gap of the shortlist and both reference cars (`hev bound`)."
            if data.get("gap")
            else ""
        )
    )
    page = template.replace("/*TITLE*/", f"sizing cycle {data['sizing_cycle']}").replace("/*INTRO*/", intro)
    # the bundles last: nothing inside them is taken for a placeholder
    page = page.replace("/*DATA*/", payload)
    page = page.replace("/*APP*/", _HERE.joinpath("app.js").read_text(encoding="utf-8").replace("</", "<\\/"))
    return page.replace("/*PLOTLY*/", plotly_bundle().replace("</script", "<\\/script"))


def write_explorer(path: str | Path, data: dict) -> None:
    """Write the page whole (temporary file, then rename)."""
    write_text(Path(path), explorer_html(data))


__all__ = ["explorer_data", "explorer_html", "plotly_bundle", "write_explorer"]
