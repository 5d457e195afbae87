"""A starting profile for another car (``hev propose``): gear ratios and a design space scaled from the study's car.

``params.yaml``'s ``baseline.conventional`` is the reference: its test mass, rated engine power, wheel radius and
overall gear ratios, and ``design_space`` its hybrids' bounds. For a car of test mass ``m``, rated engine power ``P``
and (optionally) wheel radius ``r`` the proposal scales:

- the **lower** bounds of ``p_eng_kw``, ``p_mot_kw``, ``p_gen_kw`` and ``n_bat`` with the mass ratio ``m / m0``: the
  smallest kit worth trying must still carry the car over the sizing cycle, whose road load and inertia grow with
  mass, not with how sporty the car is;
- their **upper** bounds with the power ratio ``P / P0`` (the mass ratio times the power-to-mass ratio
  ``(P / m) / (P0 / m0)``): the largest kit worth trying is one that matches the car's own performance;
- ``i0`` and the conventional car's overall ``gear_ratios`` with the radius ratio ``r / r0``, so that the engine and
  the machines turn at the same speeds at a given road speed as in the study's car (``sedan.yaml`` did the same);
- ``n_r`` and ``n_s`` (the planetary set's teeth) not at all: they set speed ratios inside the kit, not its size;
- ``screen.mass_max_kg`` to the car's test mass ("no heavier than the car it replaces"), and the DOE to a
  27-design Latin hypercube, as the study's L27 levels are the reference car's absolute values.

Given the reference car's own figures the proposal is params.yaml's design space and ratios. It is a starting
point: where the pareto report's ``active_bounds`` shows kept designs at a bound, widen that bound and rerun.
"""

from __future__ import annotations

import math
import textwrap
from dataclasses import dataclass
from pathlib import Path

import yaml

from hevlib.io import read_yaml_mapping
from hevlib.params import ParamsError, parse_params
from hevlib.profiles import apply_overrides

#: Design variables whose bounds scale with the car's size (lower: mass ratio, upper: power ratio).
SIZED = ("p_eng_kw", "p_mot_kw", "p_gen_kw", "n_bat")
#: Design variables whose bounds scale with the wheel radius.
GEARED = ("i0",)
#: Design variables that keep params.yaml's bounds.
KEPT = ("n_r", "n_s")
INTEGER = ("n_bat", "n_r", "n_s")
LHS_DESIGNS = 27


@dataclass(frozen=True)
class Reference:
    """The study's car as params.yaml gives it: what every proposal is scaled from."""

    test_mass_kg: float
    p_eng_kw: float
    wheel_radius_m: float
    gear_ratios: tuple[float, ...]
    bounds: dict[str, tuple[float, float]]

    @classmethod
    def from_params(cls, raw: dict) -> Reference:
        """From the raw params mapping (validated first, so every key read here exists and is in range)."""
        params = parse_params(raw)
        car = params.baseline.conventional
        radius = car.wheel.radius_m
        if radius is None:
            raise ParamsError("params.yaml: baseline.conventional.wheel.radius_m: needed to scale gear ratios")
        space = params.design_space
        bounds = {name: tuple(getattr(space, name)) for name in (*SIZED, *GEARED, *KEPT)}
        return cls(car.test_mass_kg, car.p_eng_kw, radius, tuple(car.gear_ratios), bounds)


@dataclass(frozen=True)
class Proposal:
    """The proposed overrides (dotted params key -> value), each with the comment saying how it was scaled."""

    entries: list[tuple[str, str, object]]

    def overrides(self) -> dict:
        return {key: value for _, key, value in self.entries}


def _positive(name: str, value: float | None, unit: str) -> None:
    if value is not None and not (math.isfinite(value) and value > 0):
        raise ValueError(f"{name}: {value:g} {unit}: must be a positive number")


def propose(
    ref: Reference,
    mass_kg: float,
    power_kw: float,
    wheel_radius_m: float | None = None,
    drag_coefficient: float | None = None,
    frontal_area_m2: float | None = None,
) -> Proposal:
    """Gear ratios and a design space for a car of ``mass_kg`` and ``power_kw`` (and ``wheel_radius_m``: else the
    reference's), scaled from ``ref`` as the module says; ``drag_coefficient`` and ``frontal_area_m2``, where
    given, replace the reference body's values."""
    _positive("--mass-kg", mass_kg, "kg")
    _positive("--power-kw", power_kw, "kW")
    _positive("--wheel-radius-m", wheel_radius_m, "m")
    _positive("--drag-coefficient", drag_coefficient, "")
    _positive("--frontal-area-m2", frontal_area_m2, "m2")
    m_ratio = mass_kg / ref.test_mass_kg
    p_ratio = power_kw / ref.p_eng_kw
    radius = ref.wheel_radius_m if wheel_radius_m is None else wheel_radius_m
    r_ratio = radius / ref.wheel_radius_m
    pm, pm0 = 1000 * power_kw / mass_kg, 1000 * ref.p_eng_kw / ref.test_mass_kg

    car = "baseline.conventional"
    entries: list[tuple[str, str, object]] = [
        (
            "the car: its test mass and rated engine power (the study's SI map scaled to it)",
            f"{car}.test_mass_kg",
            round(float(mass_kg), 1),
        ),
        ("", f"{car}.p_eng_kw", round(float(power_kw), 1)),
    ]
    if drag_coefficient is not None:
        entries.append(("body: the car's drag coefficient", f"{car}.body.drag_coefficient", float(drag_coefficient)))
    if frontal_area_m2 is not None:
        entries.append(("body: the car's frontal area (m2)", f"{car}.body.frontal_area_m2", float(frontal_area_m2)))
    if wheel_radius_m is not None:
        entries.append(("the wheels' rolling radius (m)", f"{car}.wheel.radius_m", round(float(radius), 4)))
    ratios = [round(g * r_ratio, 4) for g in ref.gear_ratios]
    entries.append(
        (
            "overall gear ratios (final drive included): params.yaml's "
            f"x {radius:g} / {ref.wheel_radius_m:g} m of wheel "
            "radius, so the engine turns as in the study's car at a given road speed"
            + (" (the same wheels: unchanged)" if r_ratio == 1 else ""),
            f"{car}.gear_ratios",
            ratios,
        )
    )
    entries.append(("the hybrid: no heavier than the car it converts", "screen.mass_max_kg", round(float(mass_kg), 1)))
    first = True
    for name in (*SIZED, *GEARED, *KEPT):
        lo, hi = ref.bounds[name]
        if name in SIZED:
            lo, hi = lo * m_ratio, hi * p_ratio
            how = f"lower x {m_ratio:.3f} (mass), upper x {p_ratio:.3f} (power)"
        elif name in GEARED:
            lo, hi = lo * r_ratio, hi * r_ratio
            how = f"x {r_ratio:.3f} (wheel radius)"
        else:
            how = "kept (the gear set's teeth set speed ratios, not size)"
        lo, hi = _rounded(name, lo, hi)
        comment = f"{name}: params.yaml's {_fmt(ref.bounds[name])}, {how}"
        if first:
            comment = (
                "the design space, scaled from params.yaml's "
                f"(the study's {ref.test_mass_kg:g} kg, {ref.p_eng_kw:g} kW "
                f"car: {pm0:.1f} W/kg; this car {pm:.1f} W/kg): lower bounds of the kit's size x the mass ratio "
                f"{m_ratio:.3f} (the smallest kit must still carry the car), upper bounds x the power ratio "
                f"{p_ratio:.3f} = mass ratio x power-to-mass ratio {pm / pm0:.3f} (the largest matches the car's own "
                f"performance). {comment}"
            )
            first = False
        entries.append((comment, f"design_space.{name}", [lo, hi]))
    entries.append(
        (
            f"the DOE: a {LHS_DESIGNS}-design Latin hypercube over this space "
            "(the study's L27 levels are absolute values "
            "of the reference car's space)",
            "doe.method",
            "lhs",
        )
    )
    entries.append(("", "doe.n_lhs", LHS_DESIGNS))
    return Proposal(entries)


def _rounded(name: str, lo: float, hi: float) -> tuple[float, float]:
    if name in INTEGER:
        lo_i, hi_i = max(1, math.floor(lo + 1e-9)), math.ceil(hi - 1e-9)
        return lo_i, max(hi_i, lo_i + 1)
    digits = 2 if name in GEARED else 1
    return round(lo, digits), round(hi, digits)


def _fmt(bounds: tuple[float, float]) -> str:
    return f"[{bounds[0]:g}, {bounds[1]:g}]"


def check_proposal(proposal: Proposal, raw: dict, where: str = "params.yaml") -> None:
    """Raise :class:`~hevlib.params.ParamsError` (one line naming the key) unless ``raw`` with the proposal's
    overrides validates."""
    parse_params(apply_overrides(raw, proposal.overrides()), f"{where} with the proposed profile")


def read_params(path: str | Path) -> dict:
    return read_yaml_mapping(path, what="params file", error=ParamsError, missing_error=ParamsError)


def render(proposal: Proposal, name: str, mass_kg: float, power_kw: float, wheel_radius_m: float | None) -> str:
    """The profile file's text: a header saying it is a starting point, then each key with its comment."""
    radius = f", {wheel_radius_m:g} m wheels" if wheel_radius_m is not None else ""
    head = [
        f"# A starting point, not an answer: a {mass_kg:g} kg, {power_kw:g} kW car{radius}, proposed by `hev propose`",
        "# (hevlib/proposal.py) from params.yaml's car and design space, each value scaled as its comment says.",
        "# Each dotted key is one `dvc exp run -S` override of params.yaml:",
        "#",
        f"#   dvc exp run $(hev profile {name})",
        "#",
    ]
    head += _comment(
        "Before trusting the answer: give the car's own body (baseline.conventional.body: drag, frontal area, or "
        "its coast-down) and wheels; after a run, widen every bound the pareto report's active_bounds lists "
        "(reports/pareto.json) and rerun (docs/your-car.md)."
    )
    body = []
    for comment, key, value in proposal.entries:
        if comment:
            body += _comment(comment)
        body.append(f"{key}: {_flow(value)}")
    return "\n".join(head + body) + "\n"


def _comment(text: str) -> list[str]:
    return textwrap.wrap(text, 113, initial_indent="# ", subsequent_indent="# ", break_on_hyphens=False)


def _flow(value: object) -> str:
    return (
        yaml.safe_dump(value, default_flow_style=True, width=float("inf"), sort_keys=False)
        .strip()
        .removesuffix("...")
        .strip()
    )
