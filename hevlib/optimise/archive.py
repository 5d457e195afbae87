"""Every simulation a source makes, in order: its archive (``data/pareto/<source>_archive.parquet``).

A source is judged on what it truly evaluated -- every design it simulated, the DOE's included for the
surrogate-assisted ones -- so the optimise stage records each simulator call with :class:`SimulationLog`
and writes the record (:data:`ARCHIVE_SCHEMA`): ``sim_index`` 1, 2, ... in call order, the design, its
simulated responses (``sim_`` names) and ``final_population`` (the optimiser's last population for a
search on the simulator, the last infill batch for the surrogate-assisted sources, every row for a
sample). Nothing is thinned or filtered here.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pandas as pd
import pyarrow as pa

from hevlib.design import BOOL_RESPONSES, DESIGN_VARS, RESPONSES
from hevlib.screen import SIM

ARCHIVE_SCHEMA = pa.schema(
    [
        pa.field("sim_index", pa.int64(), nullable=False),
        *[pa.field(v, pa.float64(), nullable=False) for v in DESIGN_VARS],
        *[pa.field(f"{SIM}{k}", pa.bool_() if k in BOOL_RESPONSES else pa.float64()) for k in RESPONSES],
        pa.field("final_population", pa.bool_(), nullable=False),
    ]
)


class SimulationLog:
    """``simulate`` that remembers every design it simulated and its responses, in call order."""

    def __init__(self, simulate: Callable[[np.ndarray], pd.DataFrame]):
        self.simulate = simulate
        self.X: list[np.ndarray] = []
        self.R: list[pd.DataFrame] = []

    def __call__(self, X: np.ndarray) -> pd.DataFrame:
        X = np.asarray(X, dtype=float)
        R = self.simulate(X).reset_index(drop=True)
        self.record(X, R)
        return R

    def record(self, X: np.ndarray, R: pd.DataFrame) -> None:
        """Add designs simulated elsewhere (the DOE) as if simulated now."""
        if len(X):
            self.X.append(np.asarray(X, dtype=float))
            self.R.append(R.reset_index(drop=True)[list(RESPONSES)])

    def __len__(self) -> int:
        return sum(len(x) for x in self.X)

    def table(self, final: np.ndarray | str | None) -> pa.Table:
        """The archive (:data:`ARCHIVE_SCHEMA`). ``final``: the final population's designs, ``"last"``
        (the last call's designs) or ``"all"``."""
        X = np.vstack(self.X) if self.X else np.zeros((0, len(DESIGN_VARS)))
        R = pd.concat(self.R, ignore_index=True) if self.R else pd.DataFrame({k: [] for k in RESPONSES})
        flag = np.zeros(len(X), dtype=bool)
        if isinstance(final, str) and final == "all":
            flag[:] = True
        elif isinstance(final, str) and final == "last":
            flag[len(X) - len(self.X[-1]) :] = True
        elif final is not None and len(final):
            latest = {row.tobytes(): i for i, row in enumerate(np.ascontiguousarray(X))}
            for row in np.ascontiguousarray(np.asarray(final, dtype=float)):
                i = latest.get(row.tobytes())
                if i is not None:
                    flag[i] = True
        cols = {"sim_index": np.arange(1, len(X) + 1, dtype=np.int64)}
        cols.update({v: X[:, j] for j, v in enumerate(DESIGN_VARS)})
        for k in RESPONSES:
            v = R[k].to_numpy()
            cols[f"{SIM}{k}"] = v.astype(bool) if k in BOOL_RESPONSES else v.astype(float)
        cols["final_population"] = flag
        return pa.table(cols, schema=ARCHIVE_SCHEMA)


__all__ = ["ARCHIVE_SCHEMA", "SimulationLog"]
