"""Names shared by every stage: design variables, objectives, responses, and the design space."""

from __future__ import annotations

import functools
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from hevlib.io import read_table

if TYPE_CHECKING:  # imported where used (design_matrix): params load without pandas
    import pandas as pd

#: The seven design variables, in the column order every array uses.
DESIGN_VARS: tuple[str, ...] = ("p_eng_kw", "p_mot_kw", "p_gen_kw", "i0", "n_bat", "n_r", "n_s")
INTEGER_VARS: tuple[str, ...] = ("n_bat", "n_r", "n_s")
INTEGER_MASK = np.array([v in INTEGER_VARS for v in DESIGN_VARS])

#: The eleven objectives of SPEC section 5 (units: kg, L/100 km, %, g/km x3, km, -, -, km/h, m/s^2).
OBJECTIVES: tuple[str, ...] = (
    "m_veh",
    "fc",
    "accel_dev",
    "hc",
    "co",
    "nox",
    "e_l",
    "speed_dev",
    "diff_soc",
    "v_max",
    "f_max",
)


def objective_indices(names: Iterable[str], *, what: str = "log_targets") -> tuple[int, ...]:
    """Positions of ``names`` in ``OBJECTIVES``; ValueError naming an unknown or repeated objective."""
    names = list(names)
    for name in names:
        if name not in OBJECTIVES:
            raise ValueError(f"{what}: unknown objective {name!r} (objectives: {', '.join(OBJECTIVES)})")
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise ValueError(f"{what}: objective {repeated[0]!r} is listed twice")
    return tuple(OBJECTIVES.index(n) for n in names)


#: The objectives that are maximised (every other one is minimised): stated here once.
MAXIMISED_OBJECTIVES: tuple[str, ...] = ("v_max", "f_max")
#: +1 minimised, -1 maximised (:data:`MAXIMISED_OBJECTIVES`).
SENSE = np.array([-1.0 if k in MAXIMISED_OBJECTIVES else 1.0 for k in OBJECTIVES])
OBJECTIVE_UNITS = {
    "m_veh": "kg",
    "fc": "L/100 km",
    "accel_dev": "%",
    "hc": "g/km",
    "co": "g/km",
    "nox": "g/km",
    "e_l": "km",
    "speed_dev": "-",
    "diff_soc": "-",
    "v_max": "km/h",
    "f_max": "m/s^2",
}
#: Extra responses every simulation reports beside the objectives.
EXTRA_RESPONSES: tuple[str, ...] = (
    "fc_soc_corrected",
    "eta_drivetrain",
    "t_0_100_s",
    "cycle_met",
    "speed_err_mean_kmh",
    "stalled",
    "accessory_unmet_kwh",
    "hc_engine_out",
    "co_engine_out",
    "nox_engine_out",
    "t_cat_light_off_s",
    "n_engine_starts",
    "e_engine_start_j",
    "eta_engine_mean",
    "accel_dev_mean_abs",
)
RESPONSES: tuple[str, ...] = OBJECTIVES + EXTRA_RESPONSES
#: Responses that are flags (bool columns); every other response is a float.
#: What the charge-balanced runs add (validation and baselines; :func:`hevlib.sim.simulator.charge_balance`).
CHARGE_BALANCE_RESPONSES: tuple[str, ...] = (
    "fc_charge_balanced",
    "charge_balance_runs",
    "charge_balance_residual",
    "charge_balanced",
    "soc_init_charge_balanced",
)
BOOL_RESPONSES: tuple[str, ...] = ("cycle_met", "stalled", "charge_balanced")
#: Units of every design variable and response (the DOE schema's field metadata, report headers, the explorer).
UNITS: dict[str, str] = {
    "p_eng_kw": "kW",
    "p_mot_kw": "kW",
    "p_gen_kw": "kW",
    "i0": "-",
    "n_bat": "modules",
    "n_r": "teeth",
    "n_s": "teeth",
    **OBJECTIVE_UNITS,
    "fc_soc_corrected": "L/100 km",
    "eta_drivetrain": "-",
    "t_0_100_s": "s",
    "cycle_met": "bool",
    "speed_err_mean_kmh": "km/h",
    "stalled": "bool",
    "accessory_unmet_kwh": "kWh",
    "hc_engine_out": "g/km",
    "co_engine_out": "g/km",
    "nox_engine_out": "g/km",
    "t_cat_light_off_s": "s",
    "n_engine_starts": "-",
    "e_engine_start_j": "J",
    "eta_engine_mean": "-",
    "accel_dev_mean_abs": "%",
    "source": "-",
    "fc_charge_balanced": "L/100 km",
    "charge_balance_runs": "-",
    "charge_balance_residual": "-",
    "charge_balanced": "bool",
    "soc_init_charge_balanced": "-",
}


@dataclass(frozen=True)
class DesignSpace:
    """Box bounds of the seven design variables (integers for n_bat, n_r, n_s)."""

    lower: np.ndarray
    upper: np.ndarray

    @classmethod
    def from_bounds(cls, bounds: dict[str, tuple[float, float]]) -> DesignSpace:
        lower = np.array([float(bounds[v][0]) for v in DESIGN_VARS])
        upper = np.array([float(bounds[v][1]) for v in DESIGN_VARS])
        if np.any(lower >= upper):
            bad = DESIGN_VARS[int(np.argmax(lower >= upper))]
            raise ValueError(f"design_space.{bad}: lower bound must be below upper bound")
        return cls(lower, upper)

    @property
    def n(self) -> int:
        return len(DESIGN_VARS)

    def check(
        self, x: np.ndarray, *, what: str = "design", integers: bool = True, first_line: int | None = None
    ) -> np.ndarray:
        """Return ``x`` as a float (n, 7) array; raise ValueError naming the first offending variable.

        ``integers=False`` accepts the continuous relaxation of n_bat, n_r, n_s (surrogates, optimisers
        before repair); the simulator always requires whole numbers. Positions are 1-based: the file's own
        line where ``first_line`` (the line of the first design) is given, else the row.
        """
        x = np.asarray(x, dtype=float)
        at = functools.partial(position, first_line=first_line)
        if x.ndim == 1:
            x = x[None, :]
        if x.ndim != 2 or x.shape[1] != len(DESIGN_VARS):
            raise ValueError(f"{what}: expected shape (n, {len(DESIGN_VARS)}) in order {DESIGN_VARS}, got {x.shape}")
        for j, name in enumerate(DESIGN_VARS):
            col = x[:, j]
            if not np.all(np.isfinite(col)):
                raise ValueError(f"{what}: {name} is not finite (NaN or inf) in {at(int(np.argmin(np.isfinite(col))))}")
            tol = 1e-9 * max(1.0, abs(self.upper[j]))
            out = (col < self.lower[j] - tol) | (col > self.upper[j] + tol)
            if np.any(out):
                i = int(np.argmax(out))
                raise ValueError(
                    f"{what}: {name}={col[i]:g} in {at(i)} is outside the design space "
                    f"[{self.lower[j]:g}, {self.upper[j]:g}]"
                )
            if integers and name in INTEGER_VARS and np.any(np.abs(col - np.round(col)) > 1e-9):
                i = int(np.argmax(np.abs(col - np.round(col)) > 1e-9))
                raise ValueError(f"{what}: {name}={col[i]:g} in {at(i)} must be an integer")
        n_r, n_s = x[:, DESIGN_VARS.index("n_r")], x[:, DESIGN_VARS.index("n_s")]
        if np.any(n_s >= n_r):
            i = int(np.argmax(n_s >= n_r))
            raise ValueError(f"{what}: impossible gear set in {at(i)}: n_s={n_s[i]:g} must be below n_r={n_r[i]:g}")
        return x


def design_vector(source) -> np.ndarray:
    """The (7,) design vector of anything holding the seven variables as attributes (a params group)."""
    return np.array([float(getattr(source, v)) for v in DESIGN_VARS])


def position(i: int, *, first_line: int | None = None) -> str:
    """Where row ``i`` (0-based) of a table stands, 1-based: ``line <n>`` of its file when ``first_line`` (the
    line of row 0) is known, else ``row <i + 1>``."""
    return f"line {i + first_line}" if first_line is not None else f"row {i + 1}"


def _shown(value) -> str:
    """A cell as the user wrote it (no Python repr): empty cells as ``empty``."""
    if value is None or (isinstance(value, float) and np.isnan(value)):
        return "empty"
    return str(value.item() if isinstance(value, np.generic) else value)


def design_matrix(table: pd.DataFrame, *, what: str = "designs", first_line: int | None = None) -> np.ndarray:
    """The (n, 7) design matrix from a table with the seven design-variable columns."""
    import pandas as pd

    missing = [v for v in DESIGN_VARS if v not in table.columns]
    if missing:
        raise ValueError(f"{what}: missing design-variable column(s) {', '.join(missing)}")
    cols = []
    for v in DESIGN_VARS:
        raw = table[v]
        num = pd.to_numeric(raw, errors="coerce")
        bad = num.isna().to_numpy() | (raw.dtype.kind == "b")  # text, empty cells, or a flag where a number belongs
        if bad.any():
            i = int(np.argmax(bad))
            raise ValueError(
                f"{what}: {v} is not a number in {position(i, first_line=first_line)} ({_shown(raw.iloc[i])})"
            )
        cols.append(num.to_numpy(dtype=float))
    return np.column_stack(cols)


def read_designs(path, space: DesignSpace | None = None, *, integers: bool = True) -> np.ndarray:
    """A user's designs file (CSV or Parquet) as an (n >= 1, 7) matrix, checked against ``space`` when given;
    one-line errors name the file, the column and the CSV's own line (1-based; a Parquet file's row): empty
    file, header only, a missing column, text or a flag where a number belongs, a value outside the space."""
    first_line = 2 if str(path).lower().endswith(".csv") else None  # line 1 is the header
    X = design_matrix(read_table(path), what=str(path), first_line=first_line)
    if len(X) == 0:
        raise ValueError(f"{path}: no designs (a header but no rows)")
    return X if space is None else space.check(X, what=str(path), integers=integers, first_line=first_line)


def gear_set_buildable(n_r: np.ndarray, n_s: np.ndarray, n_planets: int = 4, min_planet_teeth: int = 9) -> np.ndarray:
    """SPEC section 5: n_r > n_s, planet teeth (n_r - n_s)/2 whole and >= 9, (n_r + n_s) divisible by planets."""
    n_r, n_s = np.asarray(n_r), np.asarray(n_s)
    diff = n_r - n_s
    return (diff > 0) & (diff % 2 == 0) & (diff // 2 >= min_planet_teeth) & ((n_r + n_s) % n_planets == 0)


def buildable_gear_sets(space: DesignSpace, n_planets: int = 4, min_planet_teeth: int = 9) -> np.ndarray:
    """Every buildable (n_r, n_s) pair (:func:`gear_set_buildable`) inside the design space, (k, 2) ints."""
    j_r, j_s = DESIGN_VARS.index("n_r"), DESIGN_VARS.index("n_s")
    n_r, n_s = np.meshgrid(
        np.arange(np.ceil(space.lower[j_r]), np.floor(space.upper[j_r]) + 1),
        np.arange(np.ceil(space.lower[j_s]), np.floor(space.upper[j_s]) + 1),
        indexing="ij",
    )
    n_r, n_s = n_r.ravel().astype(int), n_s.ravel().astype(int)
    ok = gear_set_buildable(n_r, n_s, n_planets, min_planet_teeth)
    return np.column_stack([n_r[ok], n_s[ok]])


def nearest_gear_set(n_r: np.ndarray, n_s: np.ndarray, pairs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The buildable pair (row of ``pairs``) nearest each (n_r, n_s): least change of the ratio
    ``k = n_r / n_s`` (what the kinematics depend on), then of the ring size."""
    if len(pairs) == 0:
        raise ValueError("design_space: no buildable gear set (n_r, n_s) lies inside the bounds")
    k = np.asarray(n_r, float) / np.asarray(n_s, float)
    k_p = pairs[:, 0] / pairs[:, 1]
    cost = (k[:, None] - k_p[None, :]) ** 2 + 1e-12 * (np.asarray(n_r, float)[:, None] - pairs[None, :, 0]) ** 2
    best = np.argmin(cost, axis=1)
    return pairs[best, 0].astype(float), pairs[best, 1].astype(float)
