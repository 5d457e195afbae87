"""The reference study's tables (data/raw/paper): Table 1's two cars and a row of any study table."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hevlib.io import read_table

#: Table 1 of the study (``data/raw/paper/table1_baseline_vehicles.csv``): row name -> (our key, unit).
TABLE1_ROWS = {
    "vehicle_mass": ("test_mass_kg", "kg"),
    "engine_max_power": ("p_eng_kw", "kW"),
    "motor_max_power": ("p_mot_kw", "kW"),
    "generator_max_power": ("p_gen_kw", "kW"),
    "drag_coefficient": ("drag_coefficient", "-"),
    "frontal_area": ("frontal_area_m2", "m2"),
    "cg_height": ("cg_height_m", "m"),
    "wheel_radius": ("wheel_radius_m", "m"),
    "overall_gear_ratios": ("gear_ratios", "-"),
    "final_drive_ratio": ("final_drive_ratio", "-"),
}


def read_baseline_table(path: str | Path) -> dict[str, dict]:
    """The study's Table 1 as ``{"conventional": {...}, "prius": {...}}`` in our key names (SI units).

    Empty cells are left out; ``gear_ratios`` is a list (``;``-separated in the file).
    """
    path = Path(path)
    df = read_table(path)
    for col in ("parameter", "unit", "conventional", "prius"):
        if col not in df.columns:
            raise ValueError(f"{path}: missing column {col!r}")
    out: dict[str, dict] = {"conventional": {}, "prius": {}}
    for _, r in df.iterrows():
        if r["parameter"] not in TABLE1_ROWS:
            continue
        key, unit = TABLE1_ROWS[r["parameter"]]
        if str(r["unit"]) != unit:
            raise ValueError(f"{path}: {r['parameter']}: unit {r['unit']!r}, expected {unit!r}")
        for car in out:
            cell = r[car]
            if cell is None or (isinstance(cell, float) and np.isnan(cell)) or str(cell).strip() == "":
                continue
            try:
                vals = [float(v) for v in str(cell).split(";")]
            except ValueError:
                raise ValueError(f"{path}: {r['parameter']} ({car}): {cell!r} is not a number") from None
            out[car][key] = vals if key == "gear_ratios" else vals[0]
    for car in out:
        missing = [
            k for k in ("drag_coefficient", "frontal_area_m2", "cg_height_m", "wheel_radius_m") if k not in out[car]
        ]
        if missing:
            raise ValueError(f"{path}: {car}: missing {', '.join(missing)}")
    return out


def read_paper_row(path: str | Path, column: str, value) -> dict:
    """The row of a study table (CSV) whose ``column`` equals ``value``, as a dict (errors name the file)."""
    path = Path(path)
    df = read_table(path)
    if column not in df.columns:
        raise ValueError(f"{path}: missing column {column!r}")
    rows = df[df[column] == value]
    if rows.empty:
        raise ValueError(f"{path}: no row with {column} = {value!r}")
    cells = {k: df[k].at[rows.index[0]] for k in df.columns}  # per column: keeps int columns int
    return {k: (v.item() if isinstance(v, np.generic) else v) for k, v in cells.items()}
