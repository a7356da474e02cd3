"""`cvtdesign capacity`: the largest τ⊥ at each γ before the first contact reaches a limit (core.capacity), on
small envelopes of the shipped box and existing CVTs, without the usable-ratio bound (--max-slip 90deg; that
bound, the runaway and the pivoting: test_capacity_cobot.py); the limit and contact it names checked on the
model itself just below and just above each capacity; the safety factor on friction; the pressure limit; the
runaway where the load turns the ratio to its pole, named with its load."""
from __future__ import annotations

import contextlib
import io
import json

import numpy as np
import pytest
import yaml

from conftest import shipped_model, variant_data, variant_path, write_yaml

from cvtdesign.cli import main

from cvtdesign.core.capacity import LIMITS, RTOL, capacity, limit_codes, smallest_capacity
from cvtdesign.core.metrics import allowable_pressures
from cvtdesign.core.status import STATUS
from cvtdesign.io.limits import load_capacity

GAMMAS = {"start": "-80 deg", "stop": "80 deg", "step": "40 deg"}
KEYS = {"gamma_deg", "tau_perp_max_Nm", "tau_perp_min_Nm", "limit_max", "contact_max", "limit_min", "contact_min"}


def small(data):
    data["envelope"]["gamma"] = dict(GAMMAS)


@pytest.fixture(scope="module")
def box_and_existing(tmp_path_factory):
    """`capacity box_kim.yaml existing_kim.yaml --json --plots --max-slip 90deg` on γ −80..80° step 40°: (JSON, stdout,
    plots folder)."""
    tmp = tmp_path_factory.mktemp("capacity")
    files = []
    for name in ("box_kim", "existing_kim"):
        data = variant_data(name)
        small(data)
        files.append(write_yaml(tmp / f"{name}.yaml", data))
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        rc = main(["capacity", *map(str, files), "--json", str(tmp / "c.json"), "--plots", str(tmp / "plots"),
                   "--max-slip", "90deg"])
    assert rc == 0
    return json.loads((tmp / "c.json").read_text()), out.getvalue(), tmp / "plots"


def test_json_interface_and_every_gamma_named(box_and_existing):
    """The interface outside tools rely on: {"variants": [{"name", "capacity": [rows with KEYS]}]}; at every γ
    and sign a limit with its load: a contact's with its contact, or the runaway of the box at γ ±80° and of
    existing at −80°, τ⊥ < 0 (the search used to end there on not_converged with no number), which has no
    contact."""
    rep, out, plots = box_and_existing
    assert [v["name"] for v in rep["variants"]] == ["box_kim", "existing_kim"]
    runaways = []
    for v in rep["variants"]:
        assert [r["gamma_deg"] for r in v["capacity"]] == [-80, -40, 0, 40, 80] and v["unknown"] == 0
        for row in v["capacity"]:
            assert KEYS <= row.keys()
            for side in ("max", "min"):
                assert row[f"limit_{side}"] in LIMITS and row[f"unknown_{side}"] is None
                assert np.sign(row[f"tau_perp_{side}_Nm"]) == (1 if side == "max" else -1)
                if row[f"limit_{side}"] == "runaway":
                    runaways.append((v["name"], row["gamma_deg"], side))
                    assert row[f"contact_{side}"] is None and row[f"contacts_{side}"] == []
                else:
                    assert row[f"contact_{side}"] in row[f"contacts_{side}"]
                lo, hi = row[f"tau_perp_{side}_Nm_interval"]        # every capacity's 95 % interval, runaways too
                assert lo < row[f"tau_perp_{side}_Nm"] < hi
                assert sum(row[f"tau_perp_{side}_Nm_budget"].values()) == pytest.approx(1.0)
                assert row[f"tau_perp_{side}_Nm_interval_method"] == "first order"
        assert v["smallest"]["tau_perp_Nm_interval"][0] < v["smallest"]["tau_perp_Nm"]
    assert runaways == [("box_kim", -80, "min"), ("box_kim", 80, "max"), ("existing_kim", -80, "min")]
    assert (plots / "box_kim+existing_kim_capacity.png").stat().st_size > 10_000
    assert "box_kim: runaway at γ -80°, τ⊥ < 0 at 4.473 N·m; γ 80°, τ⊥ > 0 at 4.473 N·m" in " ".join(out.split())


def test_box_carries_more_than_existing_for_kims_reason(box_and_existing):
    """At every γ and sign the box carries more than Kim's existing CVT, also where either runs away (γ ±80°,
    the load turning the ratio to its pole).
    Why (Kim sec. 5.1): in existing, two steering rollers carry the load's moment, each with the whole lateral
    force, and the moment moves their normal forces in opposite directions, so the unloaded one slips first
    while the drive rollers still have friction to spare; the box's pole rollers act at the full moment arm,
    four sharing it (0.40–0.57 of the lateral force per N·m), and keep every normal force at the preload,
    so what slips is a drive roller and its follower, which share each tractive force: at γ = 0 when
    τ2 = 2·μ·P·r_D."""
    box, existing = rep = box_and_existing[0]["variants"]
    for b, e in zip(box["capacity"], existing["capacity"]):
        for side in ("max", "min"):
            carried = [abs(r[f"tau_perp_{side}_Nm"]) for r in (b, e)]
            assert carried[0] > 1.5 * carried[1], (b["gamma_deg"], side, carried)
            if e[f"limit_{side}"] != "runaway":
                assert e[f"limit_{side}"] == "gross_slip" and e[f"contact_{side}"] in ("S1", "S2")
            if b[f"limit_{side}"] != "runaway":
                assert b[f"limit_{side}"] == "gross_slip" and b[f"contacts_{side}"] in (["A", "A_"], ["B", "B_"])
    zero = box["capacity"][2]
    np.testing.assert_allclose(zero["tau_2_max_Nm"], 2 * 0.8 * 100 * 0.040, rtol=2 * RTOL)
    states = {}
    for name, v in zip(("box_kim", "existing_kim"), rep):       # the state at each capacity τ⊥ > 0
        m = shipped_model(name)
        rows = [r for r in v["capacity"] if r["limit_max"] == "gross_slip"]
        tau = np.array([r["tau_perp_max_Nm"] for r in rows])
        res = m.evaluate(np.radians([r["gamma_deg"] for r in rows]), tau)
        steer = [i for i, r in enumerate(m.layout.rollers) if r.role == "steering"]
        states[name] = res, steer, tau, [m.roller_names.index(r["contact_max"]) for r in rows]
    res, steer, tau, _ = states["box_kim"]
    np.testing.assert_allclose(res["N"], 100, rtol=1e-3)
    assert np.all(res["utilisation"][steer] < 0.75)
    box_lateral = np.abs(res["F_a"][steer]).max(axis=0) / tau
    res, steer, tau, k = states["existing_kim"]
    cols = np.arange(tau.size)
    other = [steer[1 - steer.index(i)] for i in k]
    assert np.all(res["N"][k, cols] < res["N"][other, cols]) and np.all(res["utilisation"][:2] < 0.96)
    np.testing.assert_allclose(np.abs(res["F_a"][k, cols]), np.abs(res["F_a"][other, cols]), rtol=1e-6)
    assert np.all(box_lateral < 0.6 * (np.abs(res["F_a"][k, cols]) / tau)[:4])   # γ −80..40 (the box's 80° runs away)


@pytest.mark.parametrize("gamma_deg", [-40, 40])
def test_the_named_limit_is_met_just_beyond_the_capacity(gamma_deg):
    """Just below each capacity (by RTOL) the point holds, every utilisation below 1; just above (by 2·RTOL)
    the model flags gross slip at the contact named (existing, both signs)."""
    m = shipped_model("existing_kim")
    cap = capacity(m, [np.radians(gamma_deg)], load_capacity(m.layout), max_slip=None)
    for side in ("max", "min"):
        tau, k = cap[f"tau_perp_{side}"][0], cap[f"contact_{side}"][0]
        res = m.evaluate(np.radians(gamma_deg), np.array([tau * (1 - RTOL), tau * (1 + 2 * RTOL)]))
        assert res["status"][0] == 0 and np.nanmax(res["utilisation"][:, 0]) < 1
        assert STATUS[res["status"][1]] == "gross_slip" and res["failed_contact"][1] == k


def test_safety_factor_counts_gross_slip_at_one_over_s(cli, make_variant, tmp_path):
    """--safety 1.5: the limiting contact's utilisation at each capacity is 1/1.5; the box's drive pair at γ = 0
    (normal forces at the preload: F linear in load) at 6.4/1.5 N·m; existing's below its capacity without
    the factor but above that divided by 1.5 (its steering roller's N falls with load)."""
    js = tmp_path / "c.json"
    files = [make_variant(n, small) for n in ("box_kim", "existing_kim")]
    rc, out, err = cli("capacity", *files, "--safety", "1.5", "--json", js, "--max-slip", "90deg")
    assert rc == 0 and err == ""
    assert "gross slip at F/(μN) = 1/1.5" in out and "reaches 1/1.5 = 0.667" in out
    box, existing = json.loads(js.read_text())["variants"]
    assert box["unknown"] == existing["unknown"] == 0 and box["safety"] == 1.5
    np.testing.assert_allclose(box["capacity"][2]["tau_perp_max_Nm"], 6.4 / 1.5, rtol=2 * RTOL)
    e0 = existing["capacity"][2]["tau_perp_max_Nm"]
    assert 2.190 / 1.5 < e0 < 2.190
    for name, v in (("box_kim", box), ("existing_kim", existing)):
        m = shipped_model(name)
        res = m.evaluate(np.radians([r["gamma_deg"] for r in v["capacity"]]),
                         [r["tau_perp_max_Nm"] for r in v["capacity"]])
        np.testing.assert_allclose(np.max(res["utilisation"], axis=0), 1 / 1.5, rtol=1e-5)


def test_pressure_limit_names_the_contact(cli, make_variant, tmp_path):
    """Urethane allowed 2.7 MPa (Kim's CVT reaches 2.89 MPa within 1 N·m): the capacity ends at the steering
    roller whose normal force the load raises, with p_max at the allowable there."""
    def edit(d):
        small(d)
        for k in ("urethane_82A", "urethane_84A"):
            d["materials"][k]["allowable_pressure"] = "2.7 MPa"
    js = tmp_path / "c.json"
    rc, out, err = cli("capacity", make_variant("existing_kim", edit), "--json", js, "--max-slip", "90deg")
    assert rc == 0 and err == ""
    rows = json.loads(js.read_text())["variants"][0]["capacity"]
    assert {r["limit_max"] for r in rows} == {r["limit_min"] for r in rows} == {"pressure"}
    m = shipped_model("existing_kim")
    res = m.evaluate(np.radians([r["gamma_deg"] for r in rows]), [r["tau_perp_max_Nm"] for r in rows])
    k = [m.roller_names.index(r["contact_max"]) for r in rows]
    assert set(k) <= {2, 3} and np.all(res["N"][k, range(5)] > 100)
    np.testing.assert_allclose(res["p_max"][k, range(5)], 2.7e6, rtol=1e-5)
    assert "pressure, S2" in out


def test_limit_codes_order_and_safety():
    """The model's own status first (lost contact, gross slip, not converged keep theirs); at a point that
    holds, utilisation ≥ 1/S is gross slip at the most utilised contact, then p_max over the allowable is
    pressure at the contact most over it; unchecked contacts (NaN allowable) never limit."""
    m = shipped_model("existing_kim")
    allow = allowable_pressures(m.layout)
    res = m.evaluate(np.radians([0.0, 0.0, 0.0]), [0.5, 1.5, 3.0])
    code, contact = limit_codes(m, res, allow)
    assert list(code) == [0, 0, STATUS.index("gross_slip")] and contact[2] == 2
    code, contact = limit_codes(m, res, allow, safety=2.5)     # S1 at 0.48 at 1.5 N·m
    assert list(code[:2]) == [0, STATUS.index("gross_slip")] and contact[1] == 2
    code, _ = limit_codes(m, res, np.full(4, np.nan), safety=2.5)
    assert code[0] == 0
    low = np.full(4, 1e6)                                      # 1 MPa: every loaded point over it
    code, contact = limit_codes(m, res, low)
    assert code[0] == len(STATUS) and contact[0] == np.nanargmax(res["p_max"][:, 0])


def test_smallest_capacity_over_gamma():
    """The smallest capacity is the least |τ⊥| over γ and sign where every search ended on a limit (the box's
    at its runaway at 80°); where a search ended on no limit below it, it is not known."""
    m = shipped_model("existing_kim")
    g = np.radians([0.0, 40.0, 80.0])
    cap = capacity(m, g, load_capacity(m.layout), max_slip=None)
    least = smallest_capacity(cap)
    taus = np.abs(np.concatenate([cap["tau_perp_max"], cap["tau_perp_min"]]))
    assert least["tau_perp"] == np.nanmin(taus) and least["limit"] == "gross_slip" and least["unknown"] == 0
    assert least["gamma"] == g[1] and m.roller_names[least["contact"]] in ("S1", "S2")
    box = shipped_model("box_kim")
    cap = capacity(box, np.radians([0.0, 80.0]), load_capacity(box.layout), max_slip=None)
    least = smallest_capacity(cap)
    assert least["limit"] == "runaway" and least["unknown"] == 0 and least["contact"] == -1
    assert least["gamma"] == np.radians(80.0) and least["side"] == "max" and abs(least["tau_perp"] - 4.4725) < 1e-3
    cap["limit_max"][1], cap["held_max"][1], cap["tau_perp_max"][1] = "not_converged", 4.0, np.nan
    least = smallest_capacity(cap)       # a search that stopped away from the pole, below every capacity
    assert np.isnan(least["tau_perp"]) and least["limit"] is None and least["unknown"] == 1
    assert least["gamma"] == np.radians(80.0) and least["side"] == "max"


# --- min_capacity: a constraint of optimise --------------------------------------------------------------------

def _capacity_study(tmp_path, capacity, design, **constraints):
    data = {"name": "t", "base": str(variant_path("box_kim")), "multistart": {"starts": 2},
            "envelope": {"gamma": {"start": "-60 deg", "stop": "60 deg", "step": "30 deg"},
                         "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "0.5 N*m"}},
            "design": design, "constraints": {"min_capacity": capacity, **constraints}}
    path = tmp_path / "study.yaml"
    path.write_text(yaml.safe_dump(data, allow_unicode=True))
    return path


@pytest.mark.slow
def test_an_optimum_under_min_capacity_carries_it_at_every_gamma(tmp_path, cli):
    """constraints.min_capacity: 6 N·m with the default traction margin 0.2: the optimum's capacity by the
    full search (capacity --safety 1/(1 − 0.2)) is at least 6 N·m at every γ of the study's envelope, both
    signs."""
    design = {"d": {"lower": "30 mm", "upper": "110 mm"}, "r_drive": {"lower": "20 mm", "upper": "60 mm"}}
    code, _, _ = cli("optimise", _capacity_study(tmp_path, "6 N*m", design, envelope_radius="160 mm"),
                     "--out", tmp_path / "o", "--json", tmp_path / "r.json")
    res = json.loads((tmp_path / "r.json").read_text())
    assert code == 0 and res["status"] == "Solve_Succeeded"
    assert cli("capacity", res["variant_file"], "--safety", 1.25, "--json", tmp_path / "c.json", "--max-slip", "90deg")[0] == 0
    cap = json.loads((tmp_path / "c.json").read_text())["variants"][0]["capacity"]
    assert len(cap) == 5 and all(c["tau_perp_max_Nm"] >= 6 - 1e-6 and c["tau_perp_min_Nm"] <= -6 + 1e-6 for c in cap)


@pytest.mark.slow
def test_a_capacity_no_design_reaches_is_named(tmp_path, cli):
    """The box's drive rollers fixed at 40 mm slip together at 0.8·μP·2r = 5.12 N·m at γ = 0 with the margin:
    5.5 N·m is out of reach whatever the steering pairs do, and optimise says which contact and where; with
    the rollers free but the envelope radius holding them small, it says the two conflict."""
    code, out, _ = cli("optimise", _capacity_study(tmp_path, "5.5 N*m", {"d": {"lower": "30 mm", "upper": "110 mm"}}),
                       "--out", tmp_path / "o")
    flat = " ".join(out.split())
    assert code != 0 and "cannot be met: capacity: capacity: (|F| − 0.8μN)/(μP) of B" in flat
    assert "at γ=+0° τ⊥=" in flat and "at the base design and at every corner of the bounds" in flat
    design = {"d": {"lower": "30 mm", "upper": "110 mm"}, "r_drive": {"lower": "20 mm", "upper": "60 mm"}}
    code, out, _ = cli("optimise", _capacity_study(tmp_path, "7 N*m", design, envelope_radius="160 mm"),
                       "--out", tmp_path / "o")
    flat = " ".join(out.split())
    assert code != 0 and "misses one of:" in flat and "envelope_radius (" in flat and "capacity (" in flat
