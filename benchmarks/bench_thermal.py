"""The floor the engine and catalyst thermal models set on simulator throughput.

    python benchmarks/bench_thermal.py [--designs 10000] [--steps 1370]

Runs :func:`hevlib.sim.powertrain.thermal.thermal_step` alone (what each drive step of either kernel calls,
with the light-off check), in parallel over designs as the kernels do, on a synthetic duty: engine on 4 s
in 7 at a steady part load (1.2 g/s fuel, 20 kW waste heat, 250 rad/s), 10 m/s, engines of 40-69 kW. A
drive kernel cannot beat this figure on a cycle of the same length, whatever its driveline solver costs.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from numba import njit, prange

from hevlib.sim.powertrain import layout as L
from hevlib.sim.powertrain import thermal as th_

ROOT = Path(__file__).resolve().parents[1]


@njit(parallel=True, cache=True)
def _run(n, n_steps, X, t_init):
    out = np.zeros((n, L.N_O))
    for i in prange(n):
        o = out[i]
        k, temp = th_.start(40.0 + i % 30, X, t_init, 1.0, o, np.empty(th_.N_SCRATCH))
        for t in range(n_steps):
            on = 1.0 if t % 7 < 4 else 0.0
            s = th_.ThermalStep(
                key_on=True,
                fuel_g_s=1.2 * on,
                q_waste_w=2e4 * on,
                w_e_rad_s=250.0 * on,
                hc_g_s=0.01 * on,
                co_g_s=0.05 * on,
                nox_g_s=0.01 * on,
                v_mps=10.0,
                dt_s=1.0,
            )
            th_.thermal_step(temp, k, X, s, o)
            th_.check_light_off(temp, X, t + 1.0, o)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--designs", type=int, default=10000)
    ap.add_argument("--steps", type=int, default=1370, help="drive steps per design (UDDS: 1370)")
    args = ap.parse_args()
    from hevlib.params import load_params
    from hevlib.sim.powertrain.thermal import start_temperatures
    from hevlib.sim.simulator import Simulator
    from hevlib.sizing import study_library

    p = load_params(ROOT / "params.yaml")
    p = p.model_copy(
        update={"baseline": p.baseline.model_copy(update={"components_dir": str(ROOT / p.baseline.components_dir)})}
    )
    sim = Simulator(study_library(p.baseline), p)
    X = sim.library.thermal["hybrid"]
    t_init = start_temperatures("cold", p.sim.ambient_c, X.t_stat_c)
    _run(2, 3, X, t_init)  # compile
    t0 = time.perf_counter()
    _run(args.designs, args.steps, X, t_init)
    wall = time.perf_counter() - t0
    print(
        json.dumps(
            {
                "designs": args.designs,
                "steps": args.steps,
                "wall_s": wall,
                "design_cycles_per_s": args.designs / wall,
                "ns_per_design_step_wall": wall / (args.designs * args.steps) * 1e9,
            },
            indent=2,
        )
    )


if __name__ == "__main__":
    main()
