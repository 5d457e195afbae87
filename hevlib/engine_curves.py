"""Engines of another technology: an ADVISOR map re-levelled to a published efficiency-versus-load curve.

ADVISOR's two engine maps are of the late 1990s (a 1.9 L Saturn, the 1998 Prius's 1.5 L). A car tested in 2022
has a better engine, above all at part load, and no public map of every engine exists. What is published is
generic: the brake efficiency of an engine family against its load, as FASTSim (NREL) carries it, one curve per
technology, efficiency against the share of rated power (:data:`CURVES`, each with its source).

:func:`relevelled_engine` makes an engine file of the project's own format from a source engine file and such a
curve. At every power ``P`` the source map's best point (its best-efficiency line,
:func:`hevlib.components.operating_line.best_efficiency_line`) gets the curve's efficiency at ``P / P_rated``;
every other point at that power keeps its efficiency *relative* to the best one:

``eta(w, T) = curve(P / P_rated) * eta_src(w, T) / eta_src_best(P)``,  ``P = w T``.

So the curve sets how efficient the engine is at each load (its level, and at the best point exactly the
published figure), the source map only where on the map that efficiency is reached (which speed and torque a
power-split controller picks, how much a gear that spins the engine faster costs). At zero power the fuel is
zero, as in FASTSim (an idling conventional engine carries its accessories, so it burns fuel). The map is written
on a uniform grid fine enough that bilinear reads follow the curve at low load (:data:`N_TORQUE` torque points).
The full-load and closed-throttle curves, masses, fuel, thermal model and the engine-out HC, CO and NOx rates
(g/s, re-read on the new grid) are the source's; the exhaust maps stored for checking are left out (the kernels
derive them from the fuel map). Nothing here is fitted to any test.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hevlib.components.files import load_engine, read_component_file
from hevlib.components.operating_line import best_efficiency_line
from hevlib.components.parts import EngineMap


@dataclass(frozen=True)
class EfficiencyCurve:
    """Brake efficiency (fuel LHV to shaft) against the share of rated power, with its source."""

    name: str
    power_fraction: tuple[float, ...]
    efficiency: tuple[float, ...]
    technology: str
    source: str

    def __post_init__(self):
        x, y = np.asarray(self.power_fraction), np.asarray(self.efficiency)
        if x.shape != y.shape or x[0] != 0.0 or x[-1] != 1.0 or np.any(np.diff(x) <= 0):
            raise ValueError(f"curve {self.name}: power fractions must rise from 0 to 1, one efficiency each")
        if np.any(y <= 0) or np.any(y >= 1):
            raise ValueError(f"curve {self.name}: efficiencies must lie in (0, 1)")

    def at(self, fraction) -> np.ndarray:
        """Efficiency at power fraction(s) ``fraction`` (linear, clamped at 0 and 1 as FASTSim clamps)."""
        return np.interp(fraction, self.power_fraction, self.efficiency)


#: FASTSim 2.1.5's power-fraction breakpoints (``fastsim/parameters.py``, ``fc_pwr_out_perc``).
FASTSIM_POWER_FRACTION = (0.0, 0.005, 0.015, 0.04, 0.06, 0.10, 0.14, 0.20, 0.40, 0.60, 0.80, 1.00)

CURVES: dict[str, EfficiencyCurve] = {
    "fastsim_si": EfficiencyCurve(
        name="fastsim_si",
        power_fraction=FASTSIM_POWER_FRACTION,
        efficiency=(0.10, 0.12, 0.16, 0.22, 0.28, 0.33, 0.35, 0.36, 0.35, 0.34, 0.32, 0.30),
        technology="spark-ignition gasoline engine of a current conventional car (port or direct injection)",
        source=(
            "FASTSim 2.1.5 (NREL, PyPI fastsim==2.1.5), fastsim/parameters.py, fc_eff_map_si against "
            "fc_pwr_out_perc: FASTSim's default curve of an SI engine (its 2016 Camry 4-cylinder template's)"
        ),
    ),
    "fastsim_prius_2016": EfficiencyCurve(
        name="fastsim_prius_2016",
        power_fraction=FASTSIM_POWER_FRACTION,
        efficiency=(0.08, 0.10, 0.26, 0.33, 0.355, 0.37, 0.38, 0.38, 0.35, 0.34, 0.33, 0.32),
        technology="Atkinson-cycle engine of a current power-split hybrid (Toyota 2ZR-FXE class)",
        source=(
            "FASTSim 2.1.5 (NREL, PyPI fastsim==2.1.5), fastsim/resources/FASTSim_py_veh_db.csv, vehicle 36 "
            "'2016 Toyota Prius Two FWD', fcEffMap (fcEffType Atkinson) against fc_pwr_out_perc"
        ),
    ),
}

#: Grid of the written map: speed points across the source's speed axis, torque points from 0 to the full-load
#: peak (uniform, so the kernels' uniform re-reading is exact; 1.25 % of peak torque per step).
N_SPEED, N_TORQUE = 41, 81
#: Powers at which the source's best-efficiency line is computed (from 0 to its peak).
N_LINE = 401


def relevelled_fuel_g_s(src: EngineMap, curve: EfficiencyCurve, speed_rad_s, torque_nm) -> np.ndarray:
    """Fuel rate (g/s) of engine ``src`` re-levelled to ``curve`` at the grid ``speed_rad_s`` x ``torque_nm``
    (module doc)."""
    w, t = np.meshgrid(np.asarray(speed_rad_s, float), np.asarray(torque_nm, float), indexing="ij")
    p_w = w * t
    line_p, line_w, line_t = best_efficiency_line(src, n_power=N_LINE)
    line_fuel = src.rate_g_s("fuel", line_w, line_t)
    best_fuel = np.interp(p_w, line_p, line_fuel)  # the source's least fuel at this power (clamped above its peak)
    fuel_src = src.rate_g_s("fuel", w, t)
    rated_w = src.peak_power_kw * 1e3
    with np.errstate(divide="ignore", invalid="ignore"):
        ideal = p_w / (curve.at(p_w / rated_w) * src.lhv_j_per_g)  # g/s on the best line
        fuel = np.where(p_w > 0, ideal * fuel_src / best_fuel, 0.0)
    if not np.all(np.isfinite(fuel)):
        raise ValueError(f"{src.name}: the re-levelled fuel map is not finite")
    return fuel


def relevelled_engine(source_path: str | Path, curve: EfficiencyCurve) -> dict:
    """The engine file (a mapping in the project's component format) of ``source_path`` re-levelled to ``curve``."""
    source_path = Path(source_path)
    d = read_component_file(source_path)
    src = load_engine(source_path)
    speed = np.linspace(src.speed_rad_s[0], src.speed_rad_s[-1], N_SPEED)
    torque = np.linspace(0.0, float(np.max(src.max_torque_nm)), N_TORQUE)
    w, t = np.meshgrid(speed, torque, indexing="ij")
    out = {k: copy.deepcopy(v) for k, v in d.items() if k not in _DROPPED}
    name = f"{source_path.stem}_{curve.name.upper()}"
    out |= {
        "source": f"derived file {name}",
        "description": (
            f"{d.get('description', source_path.stem)}; its fuel map re-levelled to a published efficiency curve: "
            f"{curve.technology}"
        ),
        "extraction": (
            f"written by `hev engine-map --source {source_path.name} --curve {curve.name}` (hevlib/engine_curves.py)"
            f": efficiency(w, T) = curve(P / P_rated) x efficiency_src(w, T) / best efficiency_src(P), P = w T; "
            f"source map: {source_path.name} ({d.get('source', '')}); curve: {curve.source}"
        ),
        "map_origin": (
            "fuel: the curve along the source's best-efficiency line, the source's relative efficiency elsewhere, "
            "zero at zero power; hc, co, nox: the source's engine-out rates (g/s) re-read bilinearly on this grid"
        ),
        "map_layout": f"every 2-D map has {N_SPEED} rows indexed by speed_axis_rad_s and {N_TORQUE} columns "
        "indexed by torque_axis_nm",
        "efficiency_curve": {
            "name": curve.name,
            "power_fraction": list(curve.power_fraction),
            "efficiency": list(curve.efficiency),
            "source": curve.source,
            "rated_power_kw": rounded(src.peak_power_kw),
        },
        "speed_axis_rad_s": rounded(speed),
        "speed_axis_rpm": rounded(speed * 30.0 / np.pi),
        "torque_axis_nm": rounded(torque),
        "max_torque_nm": rounded(src.max_torque_at(speed)),
        "closed_throttle_torque_nm": rounded(np.interp(speed, src.speed_rad_s, src.closed_throttle_torque_nm)),
        "fuel_map_g_per_s": rounded(relevelled_fuel_g_s(src, curve, speed, torque)),
    }
    for gas in ("hc", "co", "nox"):
        out[f"{gas}_map_g_per_s"] = rounded(src.rate_g_s(gas, w, t))
    for key in _DROPPED_THERMAL:
        out["thermal_model"].pop(key, None)
    out["notes"] = [
        f"Derived from {source_path.name}; nothing in it is fitted to a test.",
        "The exhaust flow and temperature maps of the source are left out: the kernels derive both from the fuel map.",
    ]
    return out


#: Keys of a source file that describe its own map only (checks and variants) and do not carry over.
_DROPPED = ("bsfc_map_g_per_kwh", "bsfc_map_note", "enriched_variant", "derived_checks", "notes", "peak_power_kw")
#: ... and of its thermal model: the exhaust maps stored for checking (the kernels derive them from the fuel map).
_DROPPED_THERMAL = ("exhaust_gas_flow_map_g_per_s", "engine_out_exhaust_temperature_map_c", "note")


def rounded(a):
    """Numbers rounded to 10 significant digits (the written file does not depend on the last bits)."""
    arr = np.asarray(a, dtype=float)
    out = np.vectorize(lambda x: float(f"{x:.10g}"))(arr) if arr.size else arr
    return out.tolist() if arr.ndim else float(out)


def engine_file(source_path: str | Path, curve_name: str) -> dict:
    """:func:`relevelled_engine` by curve name (KeyError listing the curves if unknown)."""
    if curve_name not in CURVES:
        raise KeyError(f"curve {curve_name!r}: one of {', '.join(CURVES)}")
    return relevelled_engine(source_path, CURVES[curve_name])


def render(data: dict) -> str:
    """A derived component file's YAML text (an engine's, a wheel's: the layout of the converted ADVISOR files, one
    map row per line)."""
    import yaml

    return yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=10**6, allow_unicode=True)
