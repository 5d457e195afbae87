"""The recommendation (hevlib/recommend.py): the knee, the best of each group, the shortlist, active bounds
and the reasons, on hand-made cases whose answers are known."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from test_pareto import synthetic_front

from hevlib.design import DESIGN_VARS, OBJECTIVES
from hevlib.indicators import pick_diverse
from hevlib.params import DesignSpaceParams, ScreenParams
from hevlib.pareto import select_designs
from hevlib.recommend import (
    FAMILY_SHARE,
    FLAG_SHARE,
    active_bounds,
    best_of_group,
    bounds_touched,
    knee_index,
    knee_shares,
    noise_spread,
    recommend,
    same_family,
    screen_margins,
    separation,
    shortlist,
)
from hevlib.screen import screening_rules


def test_the_knee_is_the_point_farthest_below_the_plane_of_the_extremes():
    # a convex front: (0, 1) and (1, 0) are the extremes; (0.2, 0.25) bulges most towards the ideal point
    F = np.array([[0.0, 1.0], [0.1, 0.6], [0.2, 0.25], [0.6, 0.1], [1.0, 0.0], [0.5, 0.5]])
    assert knee_index(F) == 2
    # a dominated design is never the knee, however deep
    assert knee_index(np.vstack([F, [0.25, 0.3]])) == 2
    # in three criteria, with units that differ by orders of magnitude (normalised first)
    G = np.array([[4.0, 1200.0, 12.0], [6.0, 1100.0, 12.0], [4.0, 1300.0, 9.0], [4.4, 1150.0, 10.0]])
    assert knee_index(G) == 3


def test_the_knee_falls_back_to_the_equal_weight_plane_when_the_extremes_coincide():
    F = np.array([[0.0, 0.0, 1.0], [0.2, 0.2, 0.2], [1.0, 1.0, 0.0]])  # one design is best in two criteria
    assert knee_index(F) == 1
    assert knee_index(np.array([[1.0, 2.0]])) == 0
    with pytest.raises(ValueError, match="no candidates"):
        knee_index(np.zeros((0, 2)))


def test_best_of_group_and_farthest_point_sampling_from_seeds():
    G = np.array([[1.0, 10.0], [0.0, 30.0], [0.5, 15.0]])
    assert best_of_group(G) == 2  # normalised means: 0.5, 0.5, 0.375
    F = np.array([[0.0, 0.0], [1.0, 1.0], [0.1, 0.0], [0.0, 1.0], [0.9, 1.0]])
    picked = pick_diverse(F, 4, start=[2, 2, 0])
    assert list(picked[:2]) == [2, 0] and len(set(picked)) == 4  # seeds first, once each
    assert 1 in picked and 3 in picked  # then the farthest corners
    assert list(pick_diverse(F, 1, start=[4, 1])) == [4]
    assert list(pick_diverse(F, 3, start=[1])) == list(pick_diverse(F, 3, start=1))  # one seed: the classic call


def _space():
    return DesignSpaceParams()


def test_active_bounds_flag_a_bound_that_many_kept_designs_touch():
    n = 20
    kept = pd.DataFrame({v: np.linspace(*getattr(_space(), v), n + 2)[1:-1] for v in DESIGN_VARS})
    kept.loc[: int(np.ceil(FLAG_SHARE * n)) - 1, "i0"] = 4.49  # within 1 % of the range of the upper bound 4.5
    kept.loc[0, "n_bat"] = 10
    ab = active_bounds(kept, _space())
    assert ab["by_variable"]["i0"]["upper"]["kept_at"] == int(np.ceil(FLAG_SHARE * n))
    assert [(f["variable"], f["side"]) for f in ab["flagged"]] == [("i0", "upper")]  # n_bat: 1 in 20 only
    assert "widen design_space.i0" in ab["advice"]
    x = dict(kept.iloc[0])
    assert {(b["variable"], b["side"]) for b in bounds_touched(x, _space())} == {("i0", "upper"), ("n_bat", "lower")}


def test_screen_margins_say_which_rules_are_active():
    rules = screening_rules(ScreenParams(mass_max_kg=1200.0, speed_dev_max=0.4, min_v_max_kmh=130.0))
    row = {"m_veh": 1180.0, "speed_dev": 0.1, "v_max": 131.0, "p_gen_kw": 10.0, "p_mot_kw": 30.0, "stalled": 0.0}
    m = screen_margins(row, rules)
    assert set(m) == {"speed_dev_max", "mass_max", "min_v_max"}  # the rules with a limit
    assert m["mass_max"]["active"] and m["min_v_max"]["active"] and not m["speed_dev_max"]["active"]
    assert m["mass_max"]["margin"] == pytest.approx(1180 / 1200 - 1)
    assert m["min_v_max"]["margin"] == pytest.approx(1 - 131 / 130)


def test_recommend_takes_the_knee_among_the_eligible_and_says_when_none_is():
    designs = pd.DataFrame(
        {
            "vehicle": ["a", "b", "c", "d"],
            "fc_charge_balanced": [4.0, 6.0, 4.0, 4.4],
            "m_veh": [1200.0, 1100.0, 1300.0, 1150.0],
            "t_0_100_s": [12.0, 12.0, 9.0, 10.0],
            "hc": [0.1, 0.2, 0.3, 0.4],
            "co": [1.0, 1.0, 1.0, 1.0],
            "nox": [0.1, 0.1, 0.1, 0.1],
        }
    )
    rec = recommend(designs, np.ones(4, dtype=bool))
    assert rec["design"] == "d" and rec["pool"] == 4 and rec["pool_rule"] == "eligible"
    assert rec["best"] == {"fuel": "a", "emissions": "a", "performance": "c"}
    rec = recommend(designs, np.array([True, True, True, False]))  # d fails a cycle
    assert rec["design"] != "d" and rec["pool"] == 3
    rec = recommend(designs, np.zeros(4, dtype=bool))
    assert rec["design"] == "d" and rec["pool_rule"].startswith("none eligible")


def test_the_recommend_pick_is_a_deterministic_shortlist_seeded_by_the_knee_and_the_group_bests():
    fronts = {"nsga3": synthetic_front(60, 1), "moead": synthetic_front(60, 2)}
    screen = ScreenParams(n_keep=30, n_pick=8, speed_dev_max=1.0, mass_max_kg=5000.0, pick="recommend")
    res = select_designs(fronts, screen)
    sel = res.selected.to_pandas()
    roles = res.summary.selection.roles
    assert len(sel) == 8 and set(roles) == {"knee", "best_fuel", "best_emissions", "best_performance"}
    assert set(roles.values()) <= set(sel["design_id"])
    for role, design in roles.items():
        assert role in sel.set_index("design_id").loc[design, "pick_role"].split("+")
    again = select_designs(fronts, screen.model_copy(update={"seed": 99}))  # no randomness in it
    assert list(again.selected["design_id"]) == list(res.selected["design_id"])
    kept = res.merged.filter(res.merged["kept"]).to_pandas()
    fuel = kept.loc[kept["sim_fc"].idxmin(), "design_id"]
    assert roles["best_fuel"] == fuel
    picks, seeds = shortlist(kept[[c for c in kept.columns if c.startswith("sim_")]], 8)
    assert len(picks) == 8 and set(seeds) == set(roles)
    assert set(OBJECTIVES) <= {c[4:] for c in kept.columns if c.startswith("sim_")}


# --------------------------------------------------------------------------------- near-equivalents
def test_a_knee_far_from_its_rivals_wins_every_draw_and_a_near_tie_splits_them():
    front = [np.array([[0.0, 1.0]]), np.array([[0.2, 0.25]]), np.array([[1.0, 0.0]]), np.array([[0.6, 0.6]])]
    rng = np.random.default_rng(0)
    # no twins, or twins that barely move: the knee is row 1 in every draw
    assert knee_shares(front, 200, rng).tolist() == [0.0, 1.0, 0.0, 0.0]
    twins = [np.vstack([f, f + 1e-4]) for f in front]
    np.testing.assert_array_equal(knee_shares(twins, 200, rng), [0.0, 1.0, 0.0, 0.0])
    # two designs equally deep below the plane of the extremes, each with a twin a little deeper or shallower:
    # the noise decides which is the knee, about half the time each (5 of the 9 pairs favour the first: exact
    # ties go to the lower row)
    tie = [
        np.array([[0.0, 1.0]]),
        np.array([[0.2, 0.3], [0.19, 0.29], [0.21, 0.31]]),
        np.array([[0.3, 0.2], [0.295, 0.195], [0.305, 0.205]]),
        np.array([[1.0, 0.0]]),
    ]
    shares = knee_shares(tie, 4000, np.random.default_rng(1))
    assert shares.sum() == pytest.approx(1.0) and shares[0] == shares[3] == 0.0
    assert shares[1] == pytest.approx(5 / 9, abs=0.03) and shares[2] == pytest.approx(4 / 9, abs=0.03)
    with pytest.raises(ValueError, match="at least one version"):
        knee_shares([np.zeros((0, 2))], 10, rng)


def test_noise_spread_is_the_rms_deviation_of_the_twins_from_their_design():
    versions = [np.array([[1.0, 10.0], [1.1, 10.0], [0.9, 10.0]]), np.array([[2.0, 20.0], [2.0, 22.0]])]
    np.testing.assert_allclose(noise_spread(versions), [np.sqrt(0.02 / 3), np.sqrt(4 / 3)])
    assert np.isnan(noise_spread([np.array([[1.0, 2.0]])])).all()  # no twins: no estimate


def test_families_and_what_separates_two_designs():
    space = DesignSpaceParams()
    lo, hi = space.space().lower, space.space().upper
    a = np.array([40.0, 30.0, 15.0, 3.0, 30, 70, 30])
    b = a + FAMILY_SHARE * 0.9 * (hi - lo)  # every variable a little less than 5 % of its range away
    c = a.copy()
    c[0] += 0.2 * (hi[0] - lo[0])  # the engine 20 % of its range bigger
    assert same_family(np.vstack([a, b, c]), a, lo, hi).tolist() == [True, True, False]
    x = dict(zip(DESIGN_VARS, a, strict=True))
    assert separation(x, dict(zip(DESIGN_VARS, b, strict=True)), space) == []
    sep = separation(x, dict(zip(DESIGN_VARS, c, strict=True)), space)
    assert [s["variable"] for s in sep] == ["p_eng_kw"] and sep[0]["difference"] == pytest.approx(9.0)
    assert sep[0]["share_of_range"] == pytest.approx(0.2)
