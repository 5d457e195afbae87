"""Component data as typed, immutable objects, loaded from ADVISOR's published data (data/raw/components).

One module per job: :mod:`~hevlib.components.parts` the data types, :mod:`~hevlib.components.files` reading and
normalising the raw files, :mod:`~hevlib.components.operating_line` the engine's best-efficiency line,
:mod:`~hevlib.components.library` the library the ``components`` stage writes and the simulator reads,
:mod:`~hevlib.components.tables` the reference study's tables. This package's face names what other packages use.

Maps keep the source axes in SI units. The normalised form written by the ``components`` stage
(``data/components/*.npz`` + ``library.json``) is what the simulator reads; raw YAML is read only by
that stage. Loading normalises the raw maps in four documented ways (listed in ``library.meta``):

- engine maps are extended linearly in torque (each row's Willans line) down to zero torque and up to
  the peak of the full-load curve, so every operating point at or below full load lies inside the grid
  (FC_PRIUS_JPN starts at 8.5 N*m; FC_SI63_emis stops at 135.8 N*m below its 145.2 N*m full-load peak).
  ADVISOR instead clamps the torque to the map's axis before every fuel and emission lookup
  (``lib_fuel_converter.mdl``, 'fuel use and EO emis', Saturation L2332-2339), so more torque there
  would cost no more fuel: up to 12 % less fuel than ours for the 63 kW engine at full load, 1500-4000 rpm;
- engine map values above each speed row's full-load torque are replaced by the row's last segment at
  or below full load, continued linearly, so no lookup ever blends in a value from above the full-load
  curve (FC_PRIUS_JPN's cells there are the source's flat fill, up to 0.475 efficiency);
- machine efficiency maps are reduced to the first quadrant (|speed|, |torque|; the source maps are
  mirror-symmetric), and the zero-speed row and zero-torque column, which the sources fill with a
  constant instead of a measurement, take the nearest measured row / column;
- the conventional body takes the study's Table 1 (Cd, frontal area, CG height, wheel radius).
"""

from hevlib.components.files import load_engine
from hevlib.components.library import CarFiles, ComponentLibrary, LibraryFiles, load_library
from hevlib.components.operating_line import best_efficiency_line
from hevlib.components.parts import (
    RPM,
    Accessory,
    BatteryModule,
    Body,
    Catalyst,
    EngineMap,
    EngineThermal,
    MachineMap,
    Wheel,
)
from hevlib.components.tables import read_baseline_table, read_paper_row

__all__ = [
    "RPM",
    "Accessory",
    "BatteryModule",
    "Body",
    "CarFiles",
    "Catalyst",
    "ComponentLibrary",
    "EngineMap",
    "EngineThermal",
    "LibraryFiles",
    "MachineMap",
    "Wheel",
    "best_efficiency_line",
    "load_engine",
    "load_library",
    "read_baseline_table",
    "read_paper_row",
]
