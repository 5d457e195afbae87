"""Powertrain physics as scalar numba functions (callable from Python and from the simulation kernel)."""
