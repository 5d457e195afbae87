"""What the stages that simulate share: the simulator on the components stage's maps, and the processed cycles.

Only those stages import this module, so only their code deps (``hev deps``) hold ``hevlib/sim``. The cycles
(pandas, pyarrow) and the simulator (numba kernels) load on first use, after a command has checked its inputs.
"""

from __future__ import annotations

from pathlib import Path

from stages.common import close_with_stage

CYCLES_DIR = Path("data/cycles")
COMPONENTS_DIR = Path("data/components")


def cycle_named(name: str):
    """The processed cycle ``data/cycles/<name>.parquet`` (grade and key-off periods attached)."""
    from hevlib.cycles import Cycle

    return Cycle.from_parquet(CYCLES_DIR / f"{name}.parquet", name)


def simulator(params):
    """The simulator on the components stage's normalised maps, closed when the stage ends."""
    from hevlib.sim.simulator import Simulator  # numba kernels: only loaded to simulate

    return close_with_stage(Simulator.from_params(params, components_dir=str(COMPONENTS_DIR)))


def sizing_setup(params):
    """The simulator and the sizing cycle (``cycles.sizing``, grade attached)."""
    return simulator(params), cycle_named(params.cycles.sizing)
