"""The fuzzy rule base of SPEC section 4 (``hevlib.sim.control``): rows 1-5 plus coverage rules 6, 7.

Test points are built from the repository's ``pms`` thresholds (params.yaml), each input placed
outside every fuzzy transition band, so the tests stay valid if the defaults move. Levels:
``low`` = below the lower threshold, ``mid`` = between the two thresholds, ``high`` = above the
upper one (speed has one threshold: ``low`` / ``high``).
"""

from __future__ import annotations

import numpy as np
import pytest

from hevlib.sim.control import above, decide, rule_strengths, thresholds

KEYS = ("soc_low", "soc_high", "grade_low", "grade_high", "speed_high_kmh", "torque_low", "torque_high")
INPUTS = ("soc", "grade", "speed", "torque")
SIZING_GRADE, FLAT_GRADE = 0.2, 0.0  # UDDS at 20 % grade (rise/run), flat cycles


def _below(t) -> float:
    return t.value - t.width / 2 - max(t.width, 0.01 * max(abs(t.value), 1.0))


def _over(t) -> float:
    return t.value + t.width / 2 + max(t.width, 0.01 * max(abs(t.value), 1.0))


def _between(lo, hi) -> float:
    a, b = lo.value + lo.width / 2, hi.value - hi.width / 2
    assert a < b, "transition bands overlap: no crisp 'between' region"
    return 0.5 * (a + b)


@pytest.fixture(scope="module")
def pms(params):
    return params.pms


@pytest.fixture(scope="module")
def th(pms) -> np.ndarray:
    return thresholds(pms)


@pytest.fixture(scope="module")
def lvl(pms) -> dict:
    """Crisp input levels per input, well outside the transition bands."""
    return {
        "soc": {"low": _below(pms.soc_low), "mid": _between(pms.soc_low, pms.soc_high), "high": _over(pms.soc_high)},
        "grade": {
            "low": _below(pms.grade_low),
            "mid": _between(pms.grade_low, pms.grade_high),
            "high": _over(pms.grade_high),
        },
        "speed": {"low": _below(pms.speed_high_kmh), "high": _over(pms.speed_high_kmh)},
        "torque": {
            "low": _below(pms.torque_low),
            "mid": _between(pms.torque_low, pms.torque_high),
            "high": _over(pms.torque_high),
        },
    }


def _point(lvl, levels) -> tuple:
    return tuple(lvl[name][level] for name, level in zip(INPUTS, levels, strict=True))


# (row, (soc, grade, speed, torque) levels, full strength vector r1..r7, engine ON per the table)
ROWS = {
    "1-torque-low": (1, ("low", "mid", "high", "low"), (1, 0, 0, 0, 0, 1, 0), True),
    "1-torque-high": (1, ("low", "mid", "high", "high"), (1, 0, 0, 0, 0, 1, 1), True),
    "2-soc-mid": (2, ("mid", "mid", "high", "mid"), (0, 1, 0, 0, 0, 0, 0), True),
    "2-soc-high": (2, ("high", "low", "high", "mid"), (0, 1, 0, 0, 0, 0, 0), True),
    "3-torque-mid": (3, ("mid", "mid", "low", "mid"), (0, 0, 1, 0, 0, 0, 0), False),
    "3-torque-low": (3, ("mid", "low", "low", "low"), (0, 0, 1, 0, 0, 0, 0), False),
    "4": (4, ("high", "low", "low", "low"), (0, 0, 0, 1, 0, 0, 0), False),
    "5": (5, ("high", "high", "high", "high"), (0, 0, 0, 0, 1, 0, 1), True),
}


def test_thresholds_carry_each_pms_key_by_name(pms, th):
    for k in KEYS:
        assert (getattr(th, k), getattr(th, f"{k}_width")) == (getattr(pms, k).value, getattr(pms, k).width)
    assert len(th) == 2 * len(KEYS)


@pytest.mark.parametrize("case", ROWS.values(), ids=ROWS.keys())
@pytest.mark.parametrize("currently_on", [False, True])
def test_row_fires_alone_and_sets_engine(case, currently_on, lvl, th, pms):
    row, levels, expected, engine_on = case
    r = rule_strengths(*_point(lvl, levels), th)
    assert r[row - 1] == 1.0
    assert r == pytest.approx(expected, abs=0)
    # unambiguous: ON/(ON+OFF) is 1 or 0 at these points
    assert 0.0 <= pms.engine_on_threshold < 1.0
    want, _, _ = decide(*_point(lvl, levels), th, pms.engine_on_threshold, currently_on)
    assert want is engine_on


# (case in ROWS, input moved, new level on the other side of its threshold)
CROSSINGS = [
    ("1-torque-low", "soc", "mid"),
    ("1-torque-low", "grade", "low"),
    ("1-torque-low", "speed", "low"),
    ("1-torque-low", "torque", "mid"),
    ("1-torque-high", "torque", "mid"),
    ("2-soc-mid", "soc", "low"),
    ("2-soc-mid", "grade", "high"),
    ("2-soc-mid", "speed", "low"),
    ("2-soc-mid", "torque", "low"),
    ("2-soc-mid", "torque", "high"),
    ("3-torque-mid", "soc", "low"),
    ("3-torque-mid", "soc", "high"),
    ("3-torque-mid", "grade", "high"),
    ("3-torque-mid", "speed", "high"),
    ("4", "soc", "mid"),
    ("4", "grade", "mid"),
    ("4", "speed", "high"),
    ("4", "torque", "mid"),
    ("5", "soc", "mid"),
    ("5", "grade", "mid"),
    ("5", "speed", "low"),
    ("5", "torque", "mid"),
]


@pytest.mark.parametrize("case, name, level", CROSSINGS, ids=[f"{c}-{n}-{v}" for c, n, v in CROSSINGS])
def test_crossing_one_threshold_drops_row(case, name, level, lvl, th):
    row, levels, _, _ = ROWS[case]
    moved = tuple(level if n == name else lv for n, lv in zip(INPUTS, levels, strict=True))
    assert rule_strengths(*_point(lvl, levels), th)[row - 1] == 1.0
    assert rule_strengths(*_point(lvl, moved), th)[row - 1] == 0.0


@pytest.mark.parametrize("key", KEYS)
def test_membership_edges_and_monotone(key, pms):
    v, w = getattr(pms, key).value, getattr(pms, key).width
    assert w > 0
    assert above(v - w / 2, v, w) == 0.0
    assert above(v + w / 2, v, w) == pytest.approx(1.0, abs=1e-12)
    assert above(v, v, w) == pytest.approx(0.5, abs=1e-12)
    assert above(v - w, v, w) == 0.0 and above(v + w, v, w) == 1.0
    ys = [above(x, v, w) for x in np.linspace(v - w, v + w, 201)]
    assert all(b >= a for a, b in zip(ys[:-1], ys[1:], strict=True))


@pytest.mark.parametrize("v", [0.0, 0.5, 45.0, -0.1])
def test_crisp_membership_is_a_step(v):
    assert above(v, v, 0.0) == 0.0
    assert above(np.nextafter(v, np.inf), v, 0.0) == 1.0
    assert above(np.nextafter(v, -np.inf), v, 0.0) == 0.0


def test_strengths_in_band_are_min_max_of_memberships(lvl, th, pms):
    s_lo = pms.soc_low
    for soc in np.linspace(s_lo.value - s_lo.width / 2, s_lo.value + s_lo.width / 2, 9):
        mu = above(soc, s_lo.value, s_lo.width)
        r = rule_strengths(soc, lvl["grade"]["mid"], lvl["speed"]["low"], lvl["torque"]["mid"], th)
        assert r[2] == mu and r[5] == 1.0 - mu  # rule 3 (AND) and rule 6 (SOC < low)
    r = rule_strengths(s_lo.value, lvl["grade"]["mid"], lvl["speed"]["low"], lvl["torque"]["mid"], th)
    assert r[2] == pytest.approx(0.5)  # SOC exactly at soc_low
    # rule 1's torque OR: at torque_low's value, max(1 - 0.5, above high = 0) = 0.5
    t_lo = pms.torque_low
    r = rule_strengths(lvl["soc"]["low"], lvl["grade"]["mid"], lvl["speed"]["high"], t_lo.value, th)
    assert r[0] == pytest.approx(0.5) and r[6] == 0.0


@pytest.mark.parametrize("currently_on", [False, True])
def test_no_rule_fires_keeps_current_state(currently_on, lvl, th, pms):
    point = _point(lvl, ("mid", "high", "high", "mid"))
    assert rule_strengths(*point, th) == (0.0,) * 7
    assert decide(*point, th, pms.engine_on_threshold, currently_on) == (currently_on, 0.0, 0.0)


def _grid_max(grade, lvl, th) -> np.ndarray:
    """Max strength of r1..r7 over a SOC x speed x torque grid (incl. the crisp levels) at ``grade``."""
    socs = np.union1d(np.linspace(0.0, 1.0, 41), list(lvl["soc"].values()))
    speeds = np.union1d(np.linspace(0.0, 130.0, 27), list(lvl["speed"].values()))
    torques = np.union1d(np.linspace(-0.5, 1.5, 41), list(lvl["torque"].values()))
    best = np.zeros(7)
    for s in socs:
        for v in speeds:
            for t in torques:
                best = np.maximum(best, rule_strengths(s, grade, v, t, th))
    return best


@pytest.mark.parametrize(
    "grade, never, can",
    [
        (SIZING_GRADE, (2, 3, 4), (1, 5, 6, 7)),  # UDDS at 20 %: above grade_high
        (FLAT_GRADE, (1, 5), (2, 3, 4, 6, 7)),  # flat: below grade_low
    ],
    ids=["sizing-20pct", "flat"],
)
def test_rows_that_can_fire_on_cycle_grade(grade, never, can, lvl, th):
    best = _grid_max(grade, lvl, th)
    assert [best[r - 1] for r in never] == [0.0] * len(never)
    assert [best[r - 1] for r in can] == [1.0] * len(can)
