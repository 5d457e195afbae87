"""Design of experiments: the study's Taguchi L27 array, seeded Latin hypercubes, and the DOE table.

The DOE table (``data/doe/doe.parquet``; the held-out set ``data/doe/heldout.parquet`` has the same
schema, :data:`DOE_SCHEMA`) has one row per simulated design and these columns (unit in brackets; every
field also carries its unit as Arrow field metadata ``unit``):

* design variables, ``DESIGN_VARS`` order: ``p_eng_kw`` [kW], ``p_mot_kw`` [kW], ``p_gen_kw`` [kW],
  ``i0`` [-] (float64); ``n_bat`` [modules], ``n_r`` [teeth], ``n_s`` [teeth] (int64);
* every simulator response, ``RESPONSES`` order (float64 unless noted): ``m_veh`` [kg], ``fc``
  [L/100 km], ``accel_dev`` [%], ``hc``, ``co``, ``nox`` [g/km], ``e_l`` [km], ``speed_dev`` [-] (share of
  the cycle off the trace), ``diff_soc`` [-], ``v_max`` [km/h], ``f_max`` [m/s^2], ``fc_soc_corrected``
  [L/100 km], ``eta_drivetrain`` [-], ``t_0_100_s`` [s], ``cycle_met`` (bool), ``speed_err_mean_kmh``
  [km/h], ``stalled`` (bool), ``accessory_unmet_kwh`` [kWh], ``hc_engine_out``, ``co_engine_out``,
  ``nox_engine_out`` [g/km] (``hc``, ``co``, ``nox`` are tailpipe unless ``sim.emissions: engine_out``),
  ``t_cat_light_off_s`` [s];
* ``source`` (string): ``l27``, ``lhs`` or ``heldout``.

Run metadata lives in the Parquet schema metadata (keys ``hev.*``, see :func:`run_metadata`): the cycle
name, its grade in percent, ``hevlib.MODEL_VERSION``, a fingerprint of the params that change a
simulation, and how the designs were drawn.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from hevlib import MODEL_VERSION, SIMULATOR_SOURCES, determinism, source_hash
from hevlib.design import (
    BOOL_RESPONSES,
    DESIGN_VARS,
    INTEGER_MASK,
    INTEGER_VARS,
    OBJECTIVES,
    RESPONSES,
    UNITS,
    DesignSpace,
    design_matrix,
)
from hevlib.params import sizing_simulation_keys
from hevlib.tables import write_parquet_batches

L27_FILE = "data/raw/paper/l27_assignment.csv"
METHODS = ("l27", "lhs", "both")
SOURCES = ("l27", "lhs", "heldout", "judge")  # judge: the judged scale's reference set (`hev judge`)


def _field(name: str, typ: pa.DataType) -> pa.Field:
    return pa.field(name, typ, nullable=False, metadata={"unit": UNITS[name]})


DOE_SCHEMA = pa.schema(
    [_field(v, pa.int64() if v in INTEGER_VARS else pa.float64()) for v in DESIGN_VARS]
    + [_field(r, pa.bool_() if r in BOOL_RESPONSES else pa.float64()) for r in RESPONSES]
    + [_field("source", pa.string())]
)


# ------------------------------------------------------------------------------------------ designs
def l27_designs(path: str | Path = L27_FILE) -> np.ndarray:
    """The study's Taguchi L27 assignment as a (27, 7) float array in ``DESIGN_VARS`` order."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: L27 assignment file missing")
    df = pd.read_csv(path)
    missing = [v for v in DESIGN_VARS if v not in df.columns]
    if missing:
        raise ValueError(f"{path}: missing design-variable column(s) {', '.join(missing)}")
    if len(df) != 27:
        raise ValueError(f"{path}: expected 27 runs, found {len(df)}")
    X = df[list(DESIGN_VARS)].apply(pd.to_numeric, errors="coerce").to_numpy(dtype=float)
    if not np.all(np.isfinite(X)):
        r, c = np.argwhere(~np.isfinite(X))[0]
        raise ValueError(f"{path}: {DESIGN_VARS[c]} is not a number in run {r + 1}")
    return X


def lhs_designs(space: DesignSpace, n: int, seed: int) -> np.ndarray:
    """``n`` designs from a seeded Latin hypercube over ``space``, (n, 7) in ``DESIGN_VARS`` order.

    Continuous variables are stratified over ``[lower, upper]``. Integer variables are stratified over
    the ``k`` whole numbers inside their bounds (each stratum maps to ``lower + floor(u k)``, so every
    whole number is equally likely and the values stay inside the bounds). Rows with an impossible gear
    set (``n_s >= n_r``, which the default bounds exclude) are repaired by lowering ``n_s`` to
    ``n_r - 1`` or, where that leaves its bounds, raising ``n_r``.
    """
    from scipy.stats import qmc  # scipy.stats is slow to import; only needed here

    if n < 1:
        raise ValueError(f"lhs: number of designs must be at least 1, got {n}")
    u = qmc.LatinHypercube(d=space.n, rng=np.random.default_rng(seed)).random(n)
    lo, hi = space.lower.copy(), space.upper.copy()
    lo[INTEGER_MASK], hi[INTEGER_MASK] = np.ceil(lo[INTEGER_MASK]), np.floor(hi[INTEGER_MASK])
    for j in np.flatnonzero(INTEGER_MASK):
        if hi[j] < lo[j]:
            raise ValueError(f"design_space.{DESIGN_VARS[j]}: no whole number inside the bounds")
    X = lo + u * (hi - lo)
    k = hi - lo + 1.0
    X[:, INTEGER_MASK] = np.minimum(lo + np.floor(u * k), hi)[:, INTEGER_MASK]
    return repair_gear_set(X, lo, hi)


def repair_gear_set(X: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Make ``n_s < n_r`` in every row within the integer bounds ``lo``, ``hi`` (copy)."""
    X = X.copy()
    jr, js = DESIGN_VARS.index("n_r"), DESIGN_VARS.index("n_s")
    if lo[js] >= hi[jr]:
        raise ValueError("design_space: n_s lower bound must be below the n_r upper bound (no gear set fits)")
    bad = X[:, js] >= X[:, jr]
    X[bad, js] = np.maximum(X[bad, jr] - 1.0, lo[js])
    still = X[:, js] >= X[:, jr]
    X[still, jr] = X[still, js] + 1.0
    return X


def doe_designs(
    method: str, n_lhs: int, seed: int, space: DesignSpace, l27_path: str | Path = L27_FILE
) -> tuple[np.ndarray, np.ndarray]:
    """The DOE of ``method`` (``l27``, ``lhs`` or ``both``): designs (n, 7) and their source labels (n,)."""
    if method not in METHODS:
        raise ValueError(f"doe.method: unknown method {method!r} (use {', '.join(METHODS)})")
    parts: list[tuple[np.ndarray, str]] = []
    if method in ("l27", "both"):
        parts.append((space.check(l27_designs(l27_path), what=f"{l27_path}"), "l27"))
    if method in ("lhs", "both"):
        parts.append((lhs_designs(space, n_lhs, seed), "lhs"))
    X = np.vstack([p[0] for p in parts])
    source = np.concatenate([np.full(len(p[0]), p[1], dtype=object) for p in parts])
    return X, source


# ------------------------------------------------------------------------------------- simulation
#: Designs simulated per chunk, each written as one Parquet row group: a 10^6-design DOE holds one chunk's
#: responses in memory at a time.
CHUNK_DESIGNS = 50_000


def simulated_chunks(
    sim,
    X: np.ndarray,
    source: np.ndarray | str,
    cycle,
    *,
    batch_size: int = 1000,
    chunk: int = CHUNK_DESIGNS,
    progress: Callable[[int, int], None] | None = None,
) -> Iterator[pa.Table]:
    """Simulate the hybrid designs ``X`` on ``cycle``, ``chunk`` designs at a time (each in batches of
    ``batch_size`` on the simulator's executor), yielding each chunk's DOE table (:data:`DOE_SCHEMA`,
    no run metadata). ``progress(n_done, n_total)`` counts designs over all chunks."""
    X = np.asarray(X, dtype=float)
    n = len(X)
    source = np.broadcast_to(np.asarray(source, dtype=object), (n,))
    for start in range(0, n, max(int(chunk), 1)):
        stop = min(start + max(int(chunk), 1), n)
        done = None if progress is None else (lambda k, _total, s=start: progress(s + k, n))
        responses = sim.run(X[start:stop], cycle, vehicle="hybrid", batch_size=batch_size, progress=done)
        yield doe_table(X[start:stop], responses, source[start:stop])


def simulate_designs(sim, X: np.ndarray, source: np.ndarray | str, cycle, **kwargs) -> pa.Table:
    """The whole DOE table of :func:`simulated_chunks` (same arguments; for sets that fit in memory:
    the held-out set, tests)."""
    chunks = list(simulated_chunks(sim, X, source, cycle, **kwargs))
    return pa.concat_tables(chunks) if chunks else DOE_SCHEMA.empty_table()


def doe_table(X: np.ndarray, responses: pd.DataFrame, source: np.ndarray | str) -> pa.Table:
    """Assemble designs, responses and source labels into a table with :data:`DOE_SCHEMA`."""
    X = np.asarray(X, dtype=float)
    if X.ndim != 2 or X.shape[1] != len(DESIGN_VARS):
        raise ValueError(f"doe: designs must be (n, {len(DESIGN_VARS)}), got {X.shape}")
    missing = [r for r in RESPONSES if r not in responses.columns]
    if missing:
        raise ValueError(f"simulator output: missing response column(s) {', '.join(missing)}")
    if len(responses) != len(X):
        raise ValueError(f"simulator output: {len(responses)} rows for {len(X)} designs")
    source = np.broadcast_to(np.asarray(source, dtype=object), (len(X),))
    unknown = sorted(set(source) - set(SOURCES))
    if unknown:
        raise ValueError(f"doe: unknown source label(s) {', '.join(map(str, unknown))}")
    cols: dict[str, pa.Array] = {}
    for j, v in enumerate(DESIGN_VARS):
        cols[v] = pa.array(np.round(X[:, j]).astype(np.int64) if v in INTEGER_VARS else X[:, j])
    for r in RESPONSES:
        col = responses[r].to_numpy()
        cols[r] = pa.array(col.astype(bool) if r in BOOL_RESPONSES else col.astype(float))
    cols["source"] = pa.array([str(s) for s in source], type=pa.string())
    return pa.Table.from_pydict(cols, schema=DOE_SCHEMA)


def doe_record(p) -> dict:
    """How the DOE designs of ``DoeParams`` ``p`` are drawn (stored with the table)."""
    lhs, l27 = p.method != "l27", p.method != "lhs"
    return {
        "method": p.method,
        "n_lhs": p.n_lhs if lhs else 0,
        "seed": p.seed if lhs else None,
        "l27_file": p.l27_file if l27 else None,
    }


def heldout_record(space: DesignSpace, p) -> dict:
    """How the held-out designs of ``HeldoutParams`` ``p`` are drawn (a stored set is reused if equal)."""
    return {"method": "lhs", "n": p.n, "seed": p.seed, "lower": space.lower.tolist(), "upper": space.upper.tolist()}


def simulation_fingerprint(params) -> str:
    """Short hash of everything that changes a simulated response on the sizing cycle: the model version, the
    simulator's source code, the pinned code paths of the numeric libraries (:mod:`hevlib.determinism`: glibc's
    libm rounds the kernels' ``exp`` and ``pow``) and :func:`hevlib.params.sizing_simulation_keys` (a cached
    simulated set is reused only if equal)."""
    blob = json.dumps(
        {
            "model_version": MODEL_VERSION,
            "simulator_source": source_hash(SIMULATOR_SOURCES),
            "pins": "native" if determinism.disabled() else determinism.PINNED,
            **sizing_simulation_keys(params),
        },
        sort_keys=True,
    )
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def run_metadata(cycle, params, **design: object) -> dict[str, str]:
    """Parquet schema metadata of a simulated set: cycle, grade, model version, fingerprint, design."""
    grade = np.asarray(cycle.grade, dtype=float)
    return {
        "hev.cycle": cycle.name,
        "hev.grade_pct": f"{100.0 * float(grade.mean()):g}",
        "hev.model_version": MODEL_VERSION,
        "hev.sim_fingerprint": simulation_fingerprint(params),
        "hev.design": json.dumps(design, sort_keys=True, default=str),
    }


def is_current(metadata: dict[str, str], params, **design: object) -> bool:
    """Whether a stored simulated set was made with this simulator setup and these design choices."""
    return metadata.get("hev.sim_fingerprint") == simulation_fingerprint(params) and metadata.get(
        "hev.design"
    ) == json.dumps(design, sort_keys=True, default=str)


def write_doe(path: str | Path, table: pa.Table | Iterable[pa.Table], metadata: dict[str, str]) -> int:
    """Write a DOE table, or the chunks of :func:`simulated_chunks` as they come (one row group each),
    atomically with its run metadata; returns the number of designs written."""
    return write_parquet_batches(path, [table] if isinstance(table, pa.Table) else table, DOE_SCHEMA, metadata)


def read_doe(path: str | Path) -> tuple[pd.DataFrame, dict[str, str]]:
    """A DOE (or held-out) table and its ``hev.*`` run metadata; ValueError naming a missing column."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such DOE table; run `hev doe` first")
    table = pq.read_table(path)
    missing = [c for c in DOE_SCHEMA.names if c not in table.column_names]
    if missing:
        raise ValueError(f"{path}: missing column(s) {', '.join(missing)}")
    meta = {k.decode(): v.decode() for k, v in (table.schema.metadata or {}).items() if k.startswith(b"hev.")}
    return table.select(DOE_SCHEMA.names).to_pandas(), meta


def finite_objectives(df: pd.DataFrame) -> np.ndarray:
    """Mask of rows whose eleven objectives are all finite (the rows a surrogate can learn from)."""
    return np.all(np.isfinite(df[list(OBJECTIVES)].to_numpy(dtype=float)), axis=1)


def training_data(df: pd.DataFrame, *, what: str = "designs") -> tuple[np.ndarray, np.ndarray]:
    """(X (n, 7), Y (n, 11)) of the rows a surrogate can learn from (every objective finite)."""
    df = df[finite_objectives(df)]
    return design_matrix(df, what=what), df[list(OBJECTIVES)].to_numpy(dtype=float)


# ----------------------------------------------------------------------------------------- report
def doe_summary(df: pd.DataFrame, metadata: dict[str, str]) -> dict:
    """The ``reports/doe.json`` content: counts, per-column ranges, designs that missed the cycle."""
    numeric = list(DESIGN_VARS) + [r for r in RESPONSES if r not in BOOL_RESPONSES]
    ranges = {}
    for c in numeric:
        col = df[c].to_numpy(dtype=float)
        fin = col[np.isfinite(col)]
        ranges[c] = {
            "unit": UNITS[c],
            "min": float(fin.min()) if fin.size else None,
            "max": float(fin.max()) if fin.size else None,
            "mean": float(fin.mean()) if fin.size else None,
            "n_non_finite": int(col.size - fin.size),
        }
    missed = df.index[~df["cycle_met"].to_numpy(dtype=bool)]
    failed = [
        {
            "row": int(i),
            "source": str(df.at[i, "source"]),
            **{v: float(df.at[i, v]) for v in DESIGN_VARS},
            "e_l": float(df.at[i, "e_l"]),
            "speed_dev": float(df.at[i, "speed_dev"]),
            "stalled": bool(df.at[i, "stalled"]),
            "accessory_unmet_kwh": float(df.at[i, "accessory_unmet_kwh"]),
        }
        for i in missed
    ]
    return {
        "n_designs": int(len(df)),
        "by_source": {s: int((df["source"] == s).sum()) for s in SOURCES if (df["source"] == s).any()},
        "cycle": metadata.get("hev.cycle"),
        "grade_pct": float(metadata["hev.grade_pct"]) if "hev.grade_pct" in metadata else None,
        "model_version": metadata.get("hev.model_version"),
        "n_cycle_met": int(df["cycle_met"].sum()),
        "n_cycle_not_met": len(failed),
        "n_stalled": int(df["stalled"].sum()),
        "n_non_finite_objectives": int((~finite_objectives(df)).sum()),
        "ranges": ranges,
        "cycle_not_met": failed,
    }
