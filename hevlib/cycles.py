"""Drive cycles: load a raw speed trace, check it, resample it to a fixed step and attach a road grade.

A :class:`Cycle` is immutable data in SI units (``time_s``, ``speed_mps``, ``grade`` as rise/run).
Raw files are ADVISOR CSV exports with the header ``time_s,speed_kmh``; processed cycles are Parquet
files with the explicit schema :data:`CYCLE_SCHEMA` (``data/cycles/<name>.parquet``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from hevlib.io import write_parquet

KMH = 1.0 / 3.6  # m/s per km/h

#: Raw speed columns we understand, with the factor that turns them into m/s.
RAW_SPEED_UNITS = {"speed_kmh": KMH, "speed_mps": 1.0, "speed_mph": 0.44704}

CYCLE_SCHEMA = pa.schema([
    pa.field("time_s", pa.float64(), nullable=False),
    pa.field("speed_mps", pa.float64(), nullable=False),
    pa.field("grade", pa.float64(), nullable=False),   # rise / run (0.2 = 20 %)
])


class CycleError(ValueError):
    """A malformed cycle file or trace (message names the file and the problem)."""


@dataclass(frozen=True)
class Cycle:
    """A drive cycle on a uniform time grid: arrays of equal length, SI units, grade as rise/run."""

    name: str
    time_s: np.ndarray
    speed_mps: np.ndarray
    grade: np.ndarray

    def __post_init__(self):
        for key in ("time_s", "speed_mps", "grade"):
            arr = np.array(getattr(self, key), dtype=float)
            arr.setflags(write=False)
            object.__setattr__(self, key, arr)
        _check_trace(self.name, self.time_s, self.speed_mps)
        if len(self.grade) != len(self.time_s):
            raise CycleError(f"cycle {self.name!r}: time_s, speed_mps and grade lengths differ")
        if not np.all(np.isfinite(self.grade)) or np.any(np.abs(self.grade) > 1.0):
            raise CycleError(f"cycle {self.name!r}: grade must be finite rise/run within [-1, 1]")
        dt = np.diff(self.time_s)
        if len(dt) and not np.allclose(dt, dt[0], rtol=0, atol=1e-9):
            raise CycleError(f"cycle {self.name!r}: time step is not uniform (resample it first)")

    # ------------------------------------------------------------------ derived figures
    @property
    def dt_s(self) -> float:
        return float(self.time_s[1] - self.time_s[0])

    @property
    def n_steps(self) -> int:
        return len(self.time_s)

    @property
    def duration_s(self) -> float:
        return float(self.time_s[-1] - self.time_s[0])

    @property
    def distance_m(self) -> float:
        """Trapezoidal distance of the reference trace."""
        return float(np.trapezoid(self.speed_mps, self.time_s))

    def summary(self) -> dict:
        """The figures ``reports/cycles.json`` holds for this cycle."""
        moving = self.duration_s
        return {
            "duration_s": self.duration_s,
            "distance_km": self.distance_m / 1e3,
            "v_mean_kmh": (self.distance_m / moving) * 3.6 if moving > 0 else 0.0,
            "v_max_kmh": float(np.max(self.speed_mps)) * 3.6,
            "grade": float(np.mean(self.grade)),
        }

    def with_grade(self, grade: float) -> Cycle:
        """The same trace on a constant road grade (rise/run)."""
        return Cycle(self.name, self.time_s, self.speed_mps, np.full(self.n_steps, float(grade)))

    # ------------------------------------------------------------------ persistence
    def to_parquet(self, path: str | Path) -> None:
        table = pa.table({"time_s": self.time_s, "speed_mps": self.speed_mps, "grade": self.grade},
                         schema=CYCLE_SCHEMA)
        write_parquet(path, table, metadata={"cycle": self.name})

    @classmethod
    def from_parquet(cls, path: str | Path, name: str | None = None) -> Cycle:
        path = Path(path)
        if not path.exists():
            raise FileNotFoundError(f"{path}: no such cycle file; run `hev cycles` (dvc repro cycles) first")
        table = pq.read_table(path)
        missing = [c for c in CYCLE_SCHEMA.names if c not in table.column_names]
        if missing:
            raise CycleError(f"{path}: missing column(s) {', '.join(missing)}")
        return cls(name or path.stem, *(table.column(c).to_numpy() for c in CYCLE_SCHEMA.names))


def _check_trace(where: str, time_s: np.ndarray, speed_mps: np.ndarray) -> None:
    if len(time_s) != len(speed_mps):
        raise CycleError(f"{where}: time and speed lengths differ")
    if len(time_s) < 2:
        raise CycleError(f"{where}: needs at least two points")
    if not np.all(np.isfinite(time_s)):
        raise CycleError(f"{where}: time_s has NaN or infinite values")
    if not np.all(np.isfinite(speed_mps)):
        i = int(np.argmin(np.isfinite(speed_mps)))
        raise CycleError(f"{where}: speed is NaN or infinite at row {i}")
    if np.any(np.diff(time_s) <= 0):
        i = int(np.argmax(np.diff(time_s) <= 0)) + 1
        raise CycleError(f"{where}: time is not strictly increasing at row {i} (t={time_s[i]:g} s)")
    if np.any(speed_mps < 0):
        i = int(np.argmax(speed_mps < 0))
        raise CycleError(f"{where}: negative speed at row {i} (t={time_s[i]:g} s)")


def read_raw_cycle(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read a raw cycle CSV (``time_s`` and one known speed column); return (time_s, speed_mps)."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: cycle file missing")
    try:
        df = pd.read_csv(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as err:
        raise CycleError(f"{path}: not a readable CSV ({str(err).splitlines()[0]})") from None
    if "time_s" not in df.columns:
        raise CycleError(f"{path}: missing column 'time_s'")
    speed_cols = [c for c in df.columns if c in RAW_SPEED_UNITS]
    if not speed_cols:
        other = [c for c in df.columns if c.startswith("speed")]
        hint = f" (unknown unit in {other[0]!r})" if other else ""
        raise CycleError(f"{path}: missing speed column, expected one of {', '.join(RAW_SPEED_UNITS)}{hint}")
    col = speed_cols[0]
    time_s = pd.to_numeric(df["time_s"], errors="coerce").to_numpy(dtype=float)
    speed = pd.to_numeric(df[col], errors="coerce").to_numpy(dtype=float) * RAW_SPEED_UNITS[col]
    _check_trace(str(path), time_s, speed)
    return time_s, speed


def resample(time_s: np.ndarray, speed_mps: np.ndarray, step_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Linear resample onto ``t0, t0 + step, ...`` up to the last raw time (inclusive where it falls)."""
    if step_s <= 0:
        raise CycleError("step_s must be positive")
    n = int(np.floor((time_s[-1] - time_s[0]) / step_s + 1e-9)) + 1
    grid = time_s[0] + step_s * np.arange(n)
    return grid, np.interp(grid, time_s, speed_mps)


def load_cycle(path: str | Path, *, name: str, step_s: float = 1.0, grade: float = 0.0) -> Cycle:
    """Raw CSV -> checked, resampled :class:`Cycle` on a constant grade (rise/run)."""
    time_s, speed = read_raw_cycle(path)
    grid, v = resample(time_s, speed, step_s)
    return Cycle(name, grid - grid[0], v, np.full(len(grid), float(grade)))
