"""Capacity a cobot can use (core.capacity): the usable-ratio limit (|α| past --max-slip), the runaway of the
speed ratio (the apparent axis γ + α at the pole, no steady state beyond) named with its load, and the drive
rollers that pivot on the sphere near γ = 0, on the shipped box and existing CVTs under both contact laws."""
from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import shipped_model

from cvtdesign.core.capacity import LIMITS, MAX_SLIP, POLE_TOL, RTOL, capacity
from cvtdesign.core.kinematics import wrap_axis_angle
from cvtdesign.io.limits import load_capacity

LAWS = {"kim": ("box_kim", "existing_kim"), "kalker": ("box", "existing")}


@pytest.fixture(scope="module")
def envelopes(tmp_path_factory):
    """law → bound → the `capacity --json` records of box and existing on their whole envelopes (γ −80..80°
    step 10°), at the default usable-ratio bound and with none (--max-slip 90deg)."""
    from conftest import variant_path
    from cvtdesign.cli import main
    tmp, out = tmp_path_factory.mktemp("cobot"), {}
    for law, names in LAWS.items():
        for bound in ("default", "90deg"):
            js = tmp / f"{law}_{bound}.json"
            extra = [] if bound == "default" else ["--max-slip", bound]
            assert main(["capacity", *(str(variant_path(n)) for n in names), "--json", str(js), *extra]) == 0
            out.setdefault(law, {})[bound] = json.loads(js.read_text())["variants"]
    return out


@pytest.mark.parametrize("bound", ["default", "90deg"])
@pytest.mark.parametrize("law", list(LAWS))
def test_a_number_and_a_named_limit_at_every_gamma(envelopes, law, bound):
    """At every γ of the envelope and both signs, box and existing, under either law, with or without the
    usable-ratio bound: a load of the side's sign and one of LIMITS; no search is left unknown."""
    for v in envelopes[law][bound]:
        assert len(v["capacity"]) == 17 and v["unknown"] == 0
        for row in v["capacity"]:
            for side, sign in (("max", 1), ("min", -1)):
                assert row[f"limit_{side}"] in LIMITS, (v["name"], row["gamma_deg"], side, row[f"unknown_{side}"])
                assert np.sign(row[f"tau_perp_{side}_Nm"]) == sign
        assert v["smallest"]["tau_perp_Nm"] > 0 and v["smallest"]["limit"] in LIMITS
    limits = {r[f"limit_{s}"] for v in envelopes[law][bound] for r in v["capacity"] for s in ("max", "min")}
    if bound == "default":      # 2°: what a cobot can use ends well before any contact slips
        assert limits == {"usable_ratio"}
    else:
        assert "runaway" in limits and "usable_ratio" not in limits


def test_the_usable_ratio_is_where_alpha_passes_the_bound(envelopes):
    """Each usable-ratio capacity: |α| at the capacity within 1e-4° below the default 2° bound (the search's
    bracket), and past it just beyond; the box carries more than existing at every γ (Kim sec. 5.1: its slip
    angles are smaller)."""
    for law in LAWS:
        box, existing = envelopes[law]["default"]
        for v in (box, existing):
            m = shipped_model(v["name"])
            for side in ("max", "min"):
                g = np.radians([r["gamma_deg"] for r in v["capacity"]])
                tau = np.array([r[f"tau_perp_{side}_Nm"] for r in v["capacity"]])
                alpha = np.abs(np.degrees(m.evaluate(np.concatenate([g, g]), np.concatenate([tau, tau * (1 + 4 * RTOL)]))["alpha"]))
                assert np.all(alpha[:g.size] <= 2 + 1e-9) and np.all(alpha[:g.size] > 2 - 1e-4), (v["name"], side)
                assert np.all(alpha[g.size:] > 2), (v["name"], side)
                np.testing.assert_allclose(np.abs([r[f"alpha_{side}_deg"] for r in v["capacity"]]), alpha[:g.size], rtol=1e-9)
        for b, e in zip(box["capacity"], existing["capacity"]):
            assert abs(b["tau_perp_max_Nm"]) > abs(e["tau_perp_max_Nm"]) and abs(b["tau_perp_min_Nm"]) > abs(e["tau_perp_min_Nm"])


def test_runaway_is_named_with_the_load_where_the_ratio_reaches_its_pole():
    """Without a usable-ratio bound, the box at γ = 80° (Kim's law) carries 4.4725 N·m: there the apparent axis
    γ + α stands at the pole (ω2/ω1 without bound), and 2·RTOL beyond the model has no steady state. Named
    `runaway`, with that load, where the search used to end on 'not_converged' with no number."""
    m = shipped_model("box_kim")
    cap = capacity(m, np.radians([80.0, 40.0]), load_capacity(m.layout), max_slip=None)
    assert list(cap["limit_max"]) == ["runaway", "gross_slip"] and cap["contact_max"][0] == -1
    tau = cap["tau_perp_max"][0]
    np.testing.assert_allclose(tau, 4.4725, atol=1e-3)
    res = m.evaluate(np.radians(80.0), np.array([tau, tau * (1 + 2 * RTOL)]))
    pole = np.pi / 2 - abs(wrap_axis_angle(np.radians(80.0) + res["alpha"][0]))
    assert res["ok"][0] and not res["ok"][1] and pole < np.radians(0.01) < POLE_TOL
    assert np.isfinite(cap["tau_1_max"][0]) and cap["alpha_max"][0] > np.radians(9.9)
    with_bound = capacity(m, np.radians([80.0]), load_capacity(m.layout))
    assert with_bound["limit_max"][0] == "usable_ratio" and with_bound["tau_perp_max"][0] < tau
    assert MAX_SLIP == pytest.approx(np.radians(2.0))


@pytest.mark.parametrize("name, rollers", [("box", ["B", "B_"]), ("existing", ["D2"])])
def test_drive_rollers_pivoting_at_gamma_0_are_reported(envelopes, name, rollers):
    """Under the FASTSIM law the drive rollers of the shaft that stands still at γ = 0 pivot on the sphere and
    slide: spin moment at μNℓ, with no load, their loss the whole loss there with no output (box: B and B′,
    1.38 W each). Reported in the JSON and the text as a note; it bounds no load (the capacity at γ = 0 is the
    usable ratio's, as elsewhere)."""
    v = next(v for v in envelopes["kalker"]["default"] if v["name"] == name)
    piv = v["pivoting"]
    assert piv["modelled"] and [p["gamma_deg"] for p in piv["points"]] == [0]
    p = piv["points"][0]
    assert p["contacts"] == rollers and min(p["moment_share"]) > 0.99
    m = shipped_model(name)
    res = m.evaluate(0.0, 0.0)
    k = [m.roller_names.index(r) for r in rollers]
    np.testing.assert_allclose(p["loss_W"], res["loss"][k].sum(), rtol=1e-9)
    assert p["loss_W"] > 0.9 * res["power_loss"] and (name != "box" or abs(p["loss_W"] - 2.75) < 0.01)


@pytest.mark.slow
def test_pivoting_not_modelled_under_kims_law(cli, tmp_path):
    """Kim's law has no spin moment: the pivoting is 'not modelled', never 'none'."""
    from conftest import variant_path
    js = tmp_path / "c.json"
    rc, out, _ = cli("capacity", variant_path("box_kim"), variant_path("box"), "--json", js)
    assert rc == 0
    box, kalker = json.loads(js.read_text())["variants"]
    assert box["pivoting"] == {"modelled": False, "share": 0.95, "points": []}
    flat = " ".join(out.split())
    assert "box_kim: drive rollers pivoting on the sphere: not modelled" in flat
    assert "box: at γ 0° the drive rollers B, B_ pivot on the sphere and slide" in flat
    assert "usable ratio: |α| ≤ 2°" in flat


def test_a_limit_met_without_load_carries_zero():
    """Under the FASTSIM law spin makes α without load (box at γ = 60°: 0.048°): a bound below it is met
    at zero load, and the capacity is 0 with its limit named, not null."""
    m = shipped_model("box")
    cap = capacity(m, np.radians([60.0]), load_capacity(m.layout), max_slip=np.radians(0.01))
    assert cap["tau_perp_max"][0] == 0 and cap["limit_max"][0] == "usable_ratio"
    assert cap["tau_perp_min"][0] == 0 and cap["limit_min"][0] == "usable_ratio"
    np.testing.assert_allclose(abs(cap["alpha_max"][0]), np.radians(0.048), rtol=0.05)
