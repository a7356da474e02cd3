"""Commands and library functions that had no test of their values: resteer end to end, the Pareto front and
its knee, selfcheck's exit status and its summary of a dataset that failed."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

from conftest import ROOT, shipped_model, variant_path

from cvtdesign.design.problem import build_problem
from cvtdesign.design.solve import knee, pareto_front
from cvtdesign.design.study_file import load_study
from cvtdesign.verification import selfcheck

EXISTING = variant_path("existing_kim")


# --- resteer --------------------------------------------------------------------------------------------

def test_resteer_cli_commands_and_scores(cli, tmp_path):
    """`resteer` on Kim's CVT at τ⊥ = 0.8 N·m, scored on a rig with the variant's own effects: the ideal
    command is atan(q) (Kim eq 8, equal radii); the nominal command, inverted on that same model, achieves
    the requested ratio (error below 1e-6 %); the ideal command's error is the model's ratio at atan(q),
    re-evaluated here, by Brokowski eq 23."""
    js = tmp_path / "r.json"
    q = [0.5, 1.0, 2.0]
    rc, out, err = cli("resteer", "--variant", EXISTING, "--load", "0.8 N*m", "--ratios", "0.5,1,2",
                       "--truth-effects", "drive_longitudinal_creep,steering_lateral_creep", "--json", js)
    assert rc == 0 and err == "", err
    rep = json.loads(js.read_text())
    ideal = np.array(rep["commands"]["methods"]["ideal"])
    np.testing.assert_allclose(ideal, np.arctan(q), rtol=0, atol=1e-15)
    ach = rep["achieved"]
    assert np.max(np.abs(ach["nominal"]["error_pct"])) < 1e-6
    m = shipped_model("existing_kim")
    res = m.evaluate(ideal, 0.8)
    ratio = res["omega_2"] / res["omega_1"]
    np.testing.assert_allclose(ach["ideal"]["achieved"], ratio, rtol=1e-12)
    np.testing.assert_allclose(ach["ideal"]["error_pct"], 100 * (np.array(q) - ratio) / q, rtol=1e-12)
    assert min(np.abs(ach["ideal"]["error_pct"])) > 1.0        # the load's slip is what resteering removes
    # the nominal command sits on the loaded side of the ideal one, by the slip angle at that point
    nominal = np.array(rep["commands"]["methods"]["nominal"])
    assert np.all(np.abs(nominal - ideal) > np.radians(0.5))


def test_resteer_ratio_the_loaded_model_cannot_reach(cli, tmp_path):
    """5.6 is inside the ideal law's reach over Kim's envelope (γ ≤ 80°: up to tan 80° = 5.67), but under
    −1 N·m the model needs more than 80° for it: the nominal command is 'none', explained under the table,
    null in the JSON, and is not scored (its achieved ratio and error are null too)."""
    js = tmp_path / "r.json"
    rc, out, err = cli("resteer", "--variant", EXISTING, "--load", "-1 N*m", "--ratios", "1,5.6",
                       "--truth-effects", "drive_longitudinal_creep,steering_lateral_creep", "--json", js)
    assert rc == 0 and err == "", err
    assert "none" in out and "nan" not in out and "no commanded γ inside the envelope gives that ratio" in out
    rep = json.loads(js.read_text())
    nominal = rep["commands"]["methods"]["nominal"]
    assert nominal[1] is None and np.isfinite(nominal[0])
    assert rep["achieved"]["nominal"]["achieved"][1] is None and rep["achieved"]["nominal"]["error_pct"][1] is None


# --- Pareto front and knee --------------------------------------------------------------------------------

def front(points, failed=()):
    return [{"index": k, "worst_alpha_deg": x, "power_loss_W": y, "success": k not in failed}
            for k, (x, y) in enumerate(points)]


def test_knee_of_a_convex_front():
    """On the quarter circle (1 − cos θ, 1 − sin θ), θ ∈ [0, 90°], the point farthest from the chord is θ = 45°;
    scaling each objective to [0, 1] keeps it there (the circle is scaled to itself), and a stretched copy
    (x × 7, y × 0.01) has the same knee."""
    th = np.radians(np.linspace(0, 90, 9))
    pts = np.c_[1 - np.cos(th), 1 - np.sin(th)]
    assert knee(front(pts)) == 4
    assert knee(front(pts * [7.0, 0.01])) == 4
    # an unsymmetric convex front y = 1/x on [1, 4]: the knee maximises |chord × (p − p0)|, at x = 2
    x = np.linspace(1, 4, 13)
    scaled = np.c_[(x - 1) / 3, (1 / x - 0.25) / 0.75]
    chord, rel = scaled[-1] - scaled[0], scaled - scaled[0]
    d = np.abs(chord[0] * rel[:, 1] - chord[1] * rel[:, 0])
    assert knee(front(np.c_[x, 1 / x])) == int(np.argmax(d)) == 4


def test_knee_skips_failed_points_and_short_fronts():
    th = np.radians(np.linspace(0, 90, 9))
    pts = np.c_[1 - np.cos(th), 1 - np.sin(th)]
    # the true knee failed: the next farthest successful point (θ = 33.75° or 56.25°, equally far) is chosen
    assert knee(front(pts, failed={4})) in (3, 5)
    assert knee(front(pts[:2])) == 0
    assert knee(front(pts[:2], failed={0})) == 1


@pytest.mark.slow
def test_pareto_front_of_the_box_study(tmp_path):
    """studies/box_pareto.yaml on a small envelope, 4 points: ε runs from the slip optimum's worst |α| to the
    loss optimum's; every successful point meets its ε (IPOPT's 1e-8 relaxation) and the loss falls as ε
    grows (each point's feasible set contains the previous one's); the ends are the two single-objective
    optima's worst |α|."""
    data = yaml.safe_load((ROOT / "studies" / "box_pareto.yaml").read_text())
    data["base"] = str(variant_path("box_kim"))
    data["envelope"] = {"gamma": {"start": "-60 deg", "stop": "60 deg", "step": "60 deg"},
                        "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "1 N*m"}}
    path = tmp_path / "pareto.yaml"
    path.write_text(yaml.safe_dump(data, allow_unicode=True))
    study = load_study(path)
    pts = pareto_front(study, points=4)
    assert [p["index"] for p in pts] == [0, 1, 2, 3] and all(p["success"] for p in pts)
    eps = np.array([p["eps"] for p in pts])
    worst = np.array([p["worst_alpha_deg"] for p in pts])
    loss = np.array([p["power_loss_W"] for p in pts])
    assert np.all(np.diff(eps) > 0)
    assert np.all(worst <= eps + 1e-6 * np.maximum(1, eps))
    assert np.all(np.diff(loss) <= 1e-6 * loss[:-1])
    assert loss[0] > loss[-1] * 1.001                        # a real trade-off, not one point four times
    slip = build_problem(study, kind="worst_alpha")
    assert worst[0] == pytest.approx(eps[0], rel=1e-5)       # the first point is the slip optimum
    assert slip.names == pts[0]["problem"].names
    assert knee(pts) in (1, 2)


# --- selfcheck --------------------------------------------------------------------------------------------

# (a real selfcheck run, on a Dask cluster and from another working directory: test_diagnose.py)

NULL = {"id": "null-noise1-seed0", "matrix": "rig", "kind": "null", "withheld": "-", "noise": 1.0, "verdict": "none",
        "accepted": "-", "shares": [], "lies_along": None, "correct": True, "shrink": 0.0, "signal_to_noise": 0.0,
        "signal_chi": 0.0, "seconds": 1.0, "not_measured": {}}


def test_selfcheck_exit_status_follows_the_targets(cli, monkeypatch, tmp_path):
    """Exit 0 when the targets are met, 1 when one is missed (the null dataset given a name: a false positive
    rate of 100 %, target ≤ 5 %), with the summary written either way."""
    bad = dict(NULL, verdict="steering_offset", accepted="steering_offset", correct=False)
    for results, status in (([NULL], 0), ([bad], 1)):
        monkeypatch.setattr(selfcheck, "run", lambda *a, _r=results, **k: _r)
        rc, out, err = cli("selfcheck", "--quick", "--json", tmp_path / "s.json")
        assert rc == status, err
        s = json.loads((tmp_path / "s.json").read_text())["summary"]["rig"]
        assert s["false_positive_null"] == (0.0 if status == 0 else 1.0)


def test_selfcheck_summary_of_a_failed_dataset(cli, monkeypatch, tmp_path):
    """A dataset whose diagnosis raised is recorded as wrong (selfcheck.run's error record): the summary
    counts it as a missed single, and the command prints it and exits 1."""
    failed = {"id": "single-steering_offset-offset=0.008727-noise1", "matrix": "rig", "kind": "single",
              "withheld": "steering_offset", "noise": 1.0, "verdict": "error: ValueError: boom", "accepted": "-",
              "correct": False, "shrink": None, "signal_to_noise": 0.0,
              "signal_chi": 0.0, "shares": [], "lies_along": None, "seconds": None, "not_measured": {}}
    s = selfcheck.summary([failed])
    assert s["rig"]["top1_single"] == 0.0 and s["rig"]["per_effect"]["steering_offset"]["cases"] == 1
    monkeypatch.setattr(selfcheck, "run", lambda *a, **k: [failed])
    rc, out, err = cli("selfcheck", "--quick", "--json", tmp_path / "s.json")
    assert rc == 1 and "error: ValueError: boom" in out


def test_resteer_takes_its_default_load_inside_the_envelope():
    """Without --load, resteering used the data's highest load level, even 2.5 N·m on Kim's CVT (envelope
    ±1 N·m), where the CVT slips grossly: every achieved cell read 'nan / +nan'. It now takes the highest
    level inside the envelope, and refuses data with none there."""
    from types import SimpleNamespace

    from cvtdesign.diagnosis import resteer
    from cvtdesign.errors import InputError
    from cvtdesign.io.variant import load_variant
    layout = load_variant(EXISTING)
    levels = np.round(np.arange(-2.5, 2.5001, 0.25), 10)
    assert resteer.default_load(layout, SimpleNamespace(load_levels=levels, file="d.csv")) == 1.0
    assert resteer.default_load(layout, None) == pytest.approx(1.0)
    # the top level's mean a little past the envelope by noise is still the top level, not the next one down
    noisy = SimpleNamespace(load_levels=np.array([-1.0007, -0.8, 0.0, 0.8, 1.0019]), file="d.csv")
    assert resteer.default_load(layout, noisy) == 1.0019
    with pytest.raises(InputError, match=r"d.csv: every load level of the data lies outside the envelope load range"):
        resteer.default_load(layout, SimpleNamespace(load_levels=np.array([2.0, 2.5]), file="d.csv"))
