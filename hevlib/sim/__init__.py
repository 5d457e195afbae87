"""The vehicle simulator, one wing: the Python face and the numba kernels beneath it.

- :mod:`~hevlib.sim.vehicles`: the component library and the params packed into kernel arrays once
  (``KernelLibrary``) and one typed record per batch of designs (``Vehicle.from_design``);
- :mod:`~hevlib.sim.simulator`: the pure ``simulate(vehicle, cycle, record=...)``, ``responses(...)`` of the
  objectives, and ``Simulator``, which runs batches through both on an executor (:mod:`~hevlib.sim.executor`);
- kernels: :mod:`~hevlib.sim.drive` (drive cycles), :mod:`~hevlib.sim.performance` (flat-road tests),
  :mod:`~hevlib.sim.control` (the supervisory controller), :mod:`~hevlib.sim.powertrain` (component physics).

A cycle enters the kernels as :meth:`hevlib.cycles.Cycle.to_kernel`.
"""

from __future__ import annotations

_FACE = {
    "Simulator": "hevlib.sim.simulator",
    "RunOutput": "hevlib.sim.simulator",
    "simulate": "hevlib.sim.simulator",
    "responses": "hevlib.sim.simulator",
    "energy_balance": "hevlib.sim.simulator",
    "Vehicle": "hevlib.sim.vehicles",
    "KernelLibrary": "hevlib.sim.vehicles",
}


def __getattr__(name: str):
    """The public face, imported on first use (the kernels' modules stay unloaded until then)."""
    if name in _FACE:
        import importlib

        return getattr(importlib.import_module(_FACE[name]), name)
    raise AttributeError(f"module 'hevlib.sim' has no attribute {name!r}")


__all__ = list(_FACE)
