"""Drive cycles: load a raw speed trace, check it, resample it to a fixed step and attach a road grade.

A :class:`Cycle` is immutable data in SI units (``time_s``, ``speed_mps``, ``grade`` as rise/run, and
``key_on``: False where the cycle prescribes key-off, e.g. the FTP's 10-minute soak). Raw files are
ADVISOR CSV exports with the header ``time_s,speed_kmh`` (``cycles.yaml`` beside them lists key-off
intervals); processed cycles are Parquet files with the explicit schema :data:`CYCLE_SCHEMA`
(``data/cycles/<name>.parquet``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from hevlib.io import read_yaml_mapping, write_json, write_parquet

if TYPE_CHECKING:
    from hevlib.params import CyclesParams

KMH = 1.0 / 3.6  # m/s per km/h

#: Raw speed columns we understand, with the factor that turns them into m/s.
RAW_SPEED_UNITS = {"speed_kmh": KMH, "speed_mps": 1.0, "speed_mph": 0.44704}
#: Grade columns a raw cycle may carry (factor to rise/run), and the steepest grade accepted (params' range).
RAW_GRADE_UNITS = {"grade_pct": 0.01, "grade": 1.0}
MAX_GRADE = 0.30

CYCLE_SCHEMA = pa.schema(
    [
        pa.field("time_s", pa.float64(), nullable=False),
        pa.field("speed_mps", pa.float64(), nullable=False),
        pa.field("grade", pa.float64(), nullable=False),  # rise / run (0.2 = 20 %)
        pa.field("key_on", pa.bool_(), nullable=False),  # False during prescribed key-off (no idle fuel)
    ]
)
#: Columns every cycle file must have (``key_on`` defaults to all True when absent).
REQUIRED_COLUMNS = ("time_s", "speed_mps", "grade")


class KernelCycle(NamedTuple):
    """A drive cycle as the simulator's kernels read it (:meth:`Cycle.to_kernel`): per step the speed asked for,
    the grade (rise/run) and the sine and cosine of its angle, and whether the key is on."""

    v_ref: np.ndarray  # m/s
    grade: np.ndarray
    sin_g: np.ndarray
    cos_g: np.ndarray
    key_on: np.ndarray  # bool


def grade_trig(grade: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(sin, cos) of the road angle for grades given as rise/run (``theta = atan(rise/run)``)."""
    theta = np.arctan(np.asarray(grade, dtype=float))
    return np.ascontiguousarray(np.sin(theta)), np.ascontiguousarray(np.cos(theta))


class CycleError(ValueError):
    """A malformed cycle file or trace (message names the file and the problem)."""


@dataclass(frozen=True)
class Cycle:
    """A drive cycle on a uniform time grid: arrays of equal length, SI units, grade as rise/run."""

    name: str
    time_s: np.ndarray
    speed_mps: np.ndarray
    grade: np.ndarray
    key_on: np.ndarray | None = None  # bool per step; None = key on throughout

    def __post_init__(self):
        for key in ("time_s", "speed_mps", "grade"):
            arr = np.array(getattr(self, key), dtype=float)
            arr.setflags(write=False)
            object.__setattr__(self, key, arr)
        key_on = np.ones(len(self.time_s), bool) if self.key_on is None else np.array(self.key_on, dtype=bool)
        key_on.setflags(write=False)
        object.__setattr__(self, "key_on", key_on)
        _check_trace(f"cycle {self.name!r}", self.time_s, self.speed_mps)
        if not len(self.grade) == len(self.key_on) == len(self.time_s):
            raise CycleError(f"cycle {self.name!r}: time_s, speed_mps, grade and key_on lengths differ")
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
        """The figures ``reports/cycles.json`` holds for this cycle (mean speed includes stops)."""
        return {
            "duration_s": round(self.duration_s, 6),
            "distance_km": round(self.distance_m / 1e3, 6),
            "v_mean_kmh": round(self.distance_m / self.duration_s * 3.6, 6),
            "v_max_kmh": round(float(np.max(self.speed_mps)) * 3.6, 6),
            "grade": round(float(np.mean(self.grade)), 6),
        }

    def with_grade(self, grade: float) -> Cycle:
        """The same trace on a constant road grade (rise/run)."""
        return Cycle(self.name, self.time_s, self.speed_mps, np.full(self.n_steps, float(grade)), self.key_on)

    def to_kernel(self) -> KernelCycle:
        """This cycle as the kernels read it (contiguous arrays; the road angle's sine and cosine once)."""
        sin_g, cos_g = grade_trig(self.grade)
        f = np.ascontiguousarray
        return KernelCycle(
            v_ref=f(self.speed_mps, float),
            grade=f(self.grade, float),
            sin_g=sin_g,
            cos_g=cos_g,
            key_on=f(self.key_on, bool),
        )

    # ------------------------------------------------------------------ persistence
    def to_parquet(self, path: str | Path) -> None:
        table = pa.table(
            {"time_s": self.time_s, "speed_mps": self.speed_mps, "grade": self.grade, "key_on": self.key_on},
            schema=CYCLE_SCHEMA,
        )
        write_parquet(path, table, metadata={"cycle": self.name})

    @classmethod
    def from_parquet(cls, path: str | Path, name: str | None = None) -> Cycle:
        path = Path(path)
        if not path.exists():
            raise FileNotFoundError(f"{path}: no such cycle file; run `hev cycles` (dvc repro cycles) first")
        try:
            table = pq.read_table(path)
        except (pa.ArrowInvalid, OSError) as err:
            raise CycleError(f"{path}: not a readable Parquet file ({str(err).splitlines()[0]})") from None
        missing = [c for c in REQUIRED_COLUMNS if c not in table.column_names]
        if missing:
            raise CycleError(f"{path}: missing column(s) {', '.join(missing)}")
        key_on = table.column("key_on").to_numpy() if "key_on" in table.column_names else None
        try:
            return cls(name or path.stem, *(table.column(c).to_numpy() for c in REQUIRED_COLUMNS), key_on)
        except CycleError as err:
            raise CycleError(f"{path}: {err}") from None


def _check_trace(
    where: str, time_s: np.ndarray, speed_mps: np.ndarray, *, first_line: int | None = None, speed_column="speed"
) -> None:
    """Equal lengths, >= 2 points, finite values, strictly increasing time, non-negative speed.

    Positions are reported as file lines (``first_line`` = line of the first value) or array indices.
    """

    def at(i: int) -> str:
        return f"line {i + first_line}" if first_line is not None else f"index {i}"

    if len(time_s) != len(speed_mps):
        raise CycleError(f"{where}: time and speed lengths differ")
    if len(time_s) < 2:
        raise CycleError(f"{where}: needs at least two points")
    for label, arr in (("time_s", time_s), (speed_column, speed_mps)):
        if not np.all(np.isfinite(arr)):
            i = int(np.argmin(np.isfinite(arr)))
            raise CycleError(f"{where}: {label} is missing, NaN or infinite at {at(i)}")
    if np.any(np.diff(time_s) <= 0):
        i = int(np.argmax(np.diff(time_s) <= 0)) + 1
        raise CycleError(f"{where}: time is not strictly increasing at {at(i)} (t={time_s[i]:g} s)")
    if np.any(speed_mps < 0):
        i = int(np.argmax(speed_mps < 0))
        raise CycleError(f"{where}: negative speed at {at(i)} (t={time_s[i]:g} s)")


class RawTrace(NamedTuple):
    """A raw cycle file's columns in SI: time (s), speed (m/s), and grade (rise/run; None without a column)."""

    time_s: np.ndarray
    speed_mps: np.ndarray
    grade: np.ndarray | None


def read_raw_trace(path: str | Path) -> RawTrace:
    """Read a raw cycle CSV: ``time_s``, one speed column with its unit in the name (``RAW_SPEED_UNITS``) and
    optionally one grade column (``RAW_GRADE_UNITS``); any other column is refused. A bad file raises one line
    naming the file, the column and the line."""
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
    if len(speed_cols) != 1:
        other = [c for c in df.columns if c.startswith("speed")]
        if len(speed_cols) > 1:
            raise CycleError(f"{path}: {len(speed_cols)} speed columns ({', '.join(speed_cols)}); give one")
        hint = f" (unknown unit in {other[0]!r})" if other else ""
        raise CycleError(f"{path}: missing speed column, expected one of {', '.join(RAW_SPEED_UNITS)}{hint}")
    grade_cols = [c for c in df.columns if c in RAW_GRADE_UNITS]
    unknown = [c for c in df.columns if c.startswith("grade") and c not in RAW_GRADE_UNITS]
    if unknown or len(grade_cols) > 1:
        what = f"unknown unit in {unknown[0]!r}" if unknown else f"{len(grade_cols)} grade columns"
        raise CycleError(f"{path}: {what}, expected at most one of {', '.join(RAW_GRADE_UNITS)}")
    extra = [c for c in df.columns if c != "time_s" and c not in RAW_SPEED_UNITS and c not in RAW_GRADE_UNITS]
    if extra:  # read strictly: a misspelt or stray column is refused, not silently ignored
        name = str(extra[0])  # pandas names a header's empty field "Unnamed: <index>" (a trailing comma?)
        what = (
            f"column {name!r}"
            if not name.startswith("Unnamed: ")
            else f"column {list(df.columns).index(name) + 1} (no name)"
        )
        raise CycleError(
            f"{path}: unknown {what}; a raw cycle takes time_s, one speed column ({', '.join(RAW_SPEED_UNITS)}) "
            f"and at most one grade column ({', '.join(RAW_GRADE_UNITS)})"
        )
    col = speed_cols[0]
    time_s = pd.to_numeric(df["time_s"], errors="coerce").to_numpy(dtype=float)
    speed = pd.to_numeric(df[col], errors="coerce").to_numpy(dtype=float) * RAW_SPEED_UNITS[col]
    _check_trace(str(path), time_s, speed, first_line=2, speed_column=col)
    grade = None
    if grade_cols:
        gcol = grade_cols[0]
        grade = pd.to_numeric(df[gcol], errors="coerce").to_numpy(dtype=float) * RAW_GRADE_UNITS[gcol]
        bad = ~np.isfinite(grade) | (np.abs(grade) > MAX_GRADE)
        if bad.any():
            i = int(np.argmax(bad))
            raise CycleError(
                f"{path}: {gcol} at line {i + 2} is {str(df[gcol].iloc[i])!r}: not a number within "
                f"+-{MAX_GRADE / RAW_GRADE_UNITS[gcol]:g}"
            )
    return RawTrace(time_s=time_s, speed_mps=speed, grade=grade)


def read_raw_cycle(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """``(time_s, speed_mps)`` of a raw cycle CSV (:func:`read_raw_trace`)."""
    trace = read_raw_trace(path)
    return trace.time_s, trace.speed_mps


def resample(time_s: np.ndarray, speed_mps: np.ndarray, step_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Linear resample onto ``t0, t0 + step, ...`` up to the last raw time (inclusive where it falls)."""
    if not np.isfinite(step_s) or step_s <= 0:
        raise CycleError(f"step_s: {step_s:g} must be positive")
    n = int(np.floor((time_s[-1] - time_s[0]) / step_s + 1e-9)) + 1
    if n < 2:
        span = time_s[-1] - time_s[0]
        raise CycleError(f"step_s: {step_s:g} s leaves fewer than two points of a {span:g} s trace")
    grid = time_s[0] + step_s * np.arange(n)
    return grid, np.interp(grid, time_s, speed_mps)


def key_on_mask(time_s: np.ndarray, key_off_intervals_s) -> np.ndarray:
    """True except at times inside any ``[start, end]`` key-off interval (inclusive, s)."""
    on = np.ones(len(time_s), bool)
    for start, end in key_off_intervals_s:
        on &= ~((time_s >= start - 1e-9) & (time_s <= end + 1e-9))
    return on


def load_cycle(
    path: str | Path,
    *,
    name: str,
    step_s: float = 1.0,
    grade: float | None = None,
    key_off_intervals_s=(),
    expected_points: int | None = None,
) -> Cycle:
    """Raw CSV -> checked, resampled :class:`Cycle`.

    ``grade`` (rise/run): a constant grade; None takes the file's grade column (resampled like the speed),
    or a flat road where it has none; a file with a grade column and a constant ``grade`` is refused (which
    one?). ``key_off_intervals_s`` are in the raw file's time; the cycle's time starts at 0.
    ``expected_points`` (from ``cycles.yaml``): the number of data rows the file must have, so a truncated
    file is refused.
    """
    time_s, speed, raw_grade = read_raw_trace(path)
    if expected_points is not None and len(time_s) != expected_points:
        raise CycleError(
            f"{path}: {len(time_s)} data rows, but cycles.yaml gives {expected_points} points "
            f"(truncated or padded file)"
        )
    if raw_grade is not None and grade is not None:
        raise CycleError(f"{path}: has a grade column and a constant grade is given too (grade_pct); give one")
    try:
        grid, v = resample(time_s, speed, step_s)
    except CycleError as err:
        raise CycleError(f"{path}: {err}") from None
    g = np.full(len(grid), float(grade or 0.0)) if raw_grade is None else np.interp(grid, time_s, raw_grade)
    return Cycle(name, grid - grid[0], v, g, key_on_mask(grid, key_off_intervals_s))


def _metadata_entries(raw_dir: str | Path):
    """``(cycles.yaml path, [(key, entry), ...])`` of the cycle metadata in ``raw_dir`` (none if absent)."""
    path = Path(raw_dir) / "cycles.yaml"
    if not path.exists():
        return path, []
    meta = read_yaml_mapping(path, what="cycle metadata file", error=CycleError, empty_ok=True)
    return path, list((meta.get("cycles") or {}).items())


def read_expected_points(raw_dir: str | Path) -> dict[str, int]:
    """``{csv file name: number of points}`` from ``cycles.yaml`` in ``raw_dir`` (empty if absent)."""
    path, entries = _metadata_entries(raw_dir)
    out = {}
    for key, entry in entries:
        points = entry.get("points") if isinstance(entry, dict) else None
        if points is None:
            continue
        if isinstance(points, bool) or not isinstance(points, int) or points < 2:
            raise CycleError(f"{path}: cycles.{key}.points: {points!r} is not a whole number of points")
        out[str(entry.get("file"))] = points
    return out


def read_key_off_intervals(raw_dir: str | Path) -> dict[str, list[tuple[float, float]]]:
    """``{csv file name: [(start_s, end_s), ...]}`` from ``cycles.yaml`` in ``raw_dir`` (empty if absent)."""
    path, entries = _metadata_entries(raw_dir)
    out = {}
    for key, entry in entries:
        try:
            intervals = entry.get("key_off_intervals_s") or []
            out[str(entry["file"])] = [(float(a), float(b)) for a, b in intervals]
        except (KeyError, TypeError, ValueError, AttributeError):
            msg = f"{path}: cycles.{key}: needs 'file' and [start, end] key_off_intervals_s"
            raise CycleError(msg) from None
    return out


def build_cycles(cfg: CyclesParams) -> dict[str, Cycle]:
    """Every cycle of ``params.cycles``: loaded, checked, resampled, on its grade (``grade_pct / 100``)."""
    raw = Path(cfg.raw_dir)
    if not raw.is_dir():
        raise FileNotFoundError(f"{raw}: cycle directory missing (params cycles.raw_dir)")
    key_off = read_key_off_intervals(raw)
    points = read_expected_points(raw)
    return {
        name: load_cycle(
            raw / spec.file,
            name=name,
            step_s=cfg.step_s,
            grade=None if spec.grade_pct is None else spec.grade_pct / 100.0,
            key_off_intervals_s=key_off.get(spec.file, ()),
            expected_points=points.get(spec.file),
        )
        for name, spec in cfg.cycles.items()
    }


def write_cycles(cycles: Mapping[str, Cycle], out_dir: str | Path, report_path: str | Path) -> None:
    """``<out_dir>/<name>.parquet`` per cycle (stale ``*.parquet`` removed) and the summary JSON."""
    out_dir = Path(out_dir)
    for name, cyc in cycles.items():
        cyc.to_parquet(out_dir / f"{name}.parquet")
    keep = {out_dir / f"{name}.parquet" for name in cycles}
    for stale in set(out_dir.glob("*.parquet")) - keep:
        stale.unlink()
    write_json(report_path, {name: cyc.summary() for name, cyc in cycles.items()})
