"""Write ``tests/data/kernel_reference.parquet``: the drive kernels' responses on a fixed set of designs,
the reference every faster or restructured kernel must reproduce (``tests/test_kernel_reference.py``).

    python ci/kernel_reference.py            # from the repository root, with the project's venv

Designs: a seeded Latin hypercube over the default design space plus every corner of the box whose gear
set exists (``n_s < n_r``); cycles: UDDS at the sizing grade, flat UDDS, and FTP (cold start, soak).
Regenerate it only with a deliberate change of the physics (and say so in the commit), never to make a
kernel change pass.
"""

from __future__ import annotations

import itertools
import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "tests" / "data" / "kernel_reference.parquet"
N_LHS, SEED = 250, 16


def designs(space) -> np.ndarray:
    from hevlib.doe import lhs_designs

    corners = np.array(list(itertools.product(*zip(space.lower, space.upper, strict=True))))
    corners = corners[corners[:, 6] < corners[:, 5]]  # n_s < n_r: a gear set that exists
    return np.vstack([lhs_designs(space, N_LHS, SEED), corners])


def cases(cycles: dict) -> dict:
    return {"udds": cycles["udds"], "udds_flat": cycles["udds"].with_grade(0.0), "ftp": cycles["ftp"]}


def responses(sim, X: np.ndarray, cycles: dict) -> pd.DataFrame:
    """Responses of ``X`` on every reference case, stacked, with the design and the case name."""
    from hevlib.design import DESIGN_VARS

    frames = []
    for name, cyc in cases(cycles).items():
        r = sim.run(X, cyc, batch_size=len(X))
        r.insert(0, "case", name)
        for j, v in enumerate(DESIGN_VARS):
            r.insert(1 + j, v, X[:, j])
        frames.append(r)
    return pd.concat(frames, ignore_index=True)


def main() -> None:
    sys.path.insert(0, str(ROOT))
    from hevlib.cycles import build_cycles
    from hevlib.params import load_params
    from hevlib.sim.simulator import Simulator
    from hevlib.sizing import study_library

    p = load_params(ROOT / "params.yaml")
    p = p.model_copy(
        update={
            "cycles": p.cycles.model_copy(update={"raw_dir": str(ROOT / p.cycles.raw_dir)}),
            "baseline": p.baseline.model_copy(update={"components_dir": str(ROOT / p.baseline.components_dir)}),
        }
    )
    sim = Simulator(study_library(p.baseline), p)
    table = responses(sim, designs(sim.space), build_cycles(p.cycles))
    OUT.parent.mkdir(parents=True, exist_ok=True)
    table.to_parquet(OUT, index=False)
    print(f"{OUT.relative_to(ROOT)}: {len(table)} rows ({table['case'].nunique()} cases)")


if __name__ == "__main__":
    main()
