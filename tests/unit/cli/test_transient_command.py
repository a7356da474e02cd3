"""`cvtdesign transient`: the JSON interface outside tools read (issue 37, docs/dynamics.md), a figure where the
physics stopped holding null with its reason, the assumed parameters said wherever the figures are, the
figures and report, and its refusals. The default checks run --quick (no fastest-change search, no
rendering); the whole run on both machines is a slow check."""
from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import ROOT

from cvtdesign.cli import main
from cvtdesign.core.dynamics.linear import Linear
from cvtdesign.core.dynamics.response import FastestChange, Step
from cvtdesign.uses import transient as uses

BOX, EXISTING = str(ROOT / "variants" / "box.yaml"), str(ROOT / "variants" / "existing.yaml")
VARIANT_KEYS = {"name", "step", "max_rate_deg_s", "max_rate_limit", "bandwidth_Hz"}        # the interface
STEP_KEYS = {"gamma_from_deg", "gamma_to_deg", "load_Nm", "rise_s", "settle_s", "overshoot_pct", "lag_s"}
POINT_KEYS = {"gamma_deg", "load_Nm", "f3dB_Hz"}


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("transient")
    argv = ["transient", BOX, EXISTING, "--quick", "--json", str(out / "t.json"), "--plots", str(out / "plots"),
            "--report", str(out / "t.html")]
    assert main(argv) == 0
    return out


def _number(x) -> bool:
    return isinstance(x, float) and np.isfinite(x)


def test_json_has_the_interfaces_keys_and_types(quick_run):
    data = json.loads((quick_run / "t.json").read_text())
    assert set(data) == {"variants"} and [v["name"] for v in data["variants"]] == ["box", "existing"]
    for v in data["variants"]:
        assert VARIANT_KEYS <= set(v) and STEP_KEYS <= set(v["step"])
        s = v["step"]
        assert (s["gamma_from_deg"], s["gamma_to_deg"], s["load_Nm"]) == (10.0, 40.0, 0.5)   # the defaults
        assert all(_number(s[k]) and s[k] >= 0 for k in ("rise_s", "settle_s", "overshoot_pct", "lag_s"))
        assert 0 < s["lag_s"] < s["settle_s"] and s["reason"] is None
        assert [(p["gamma_deg"], p["load_Nm"]) for p in v["bandwidth_Hz"]] == [(10.0, 0.5), (25.0, 0.5), (40.0, 0.5)]
        for p in v["bandwidth_Hz"]:
            assert POINT_KEYS <= set(p) and _number(p["f3dB_Hz"]) and p["f3dB_Hz"] > 0 and p["reason"] is None
        # --quick: no fastest-change search and no rendering, each null with its reason, never a number
        assert v["max_rate_deg_s"] is None and v["max_rate_limit"] is None and v["max_rate_reason"] == uses.QUICK
        assert v["rendering"]["rms_error_dynamic"] is None and v["rendering"]["reason"] == uses.QUICK
        # what the figures rest on: every default is named, with its source
        p = v["parameters"]
        assert "motor_torque" in p["assumed"] and p["values"]["motor_torque"]["source"].startswith("assumed")
        assert p["values"]["motor_torque"] == {"value": 4.0, "unit": "N·m", "source": p["values"]["motor_torque"]["source"]}
        assert all(p["values"][k]["source"].startswith("variant") == (k not in p["assumed"]) for k in p["values"])


def test_table_footer_figures_and_report(quick_run, capsys):
    """The figures and the report are written, and the report says which parameters are assumed, as the
    printed footer does."""
    for f in ("box+existing_step.png", "box+existing_bode.png"):
        assert (quick_run / "plots" / f).read_bytes().startswith(b"\x89PNG")
    assert not (quick_run / "plots" / "box+existing_render.png").exists()      # nothing rendered with --quick
    html = (quick_run / "t.html").read_text()
    assert "cvtdesign transient" in html and html.count("<img") == 2
    assert "rest on assumed parameters" in html and "motor_torque 4 N·m" in html and "not computed (--quick)" in html


def test_printed_table_is_side_by_side(capsys):
    assert main(["transient", EXISTING, "--quick", "--bandwidth-at", "20 deg", "--load", "-0.25 N*m"]) == 0
    out = capsys.readouterr().out
    assert "bandwidth γ_axis/γ_cmd at γ 20° [Hz]" in out and "-0.25" in out
    assert "rest on assumed parameters" in out and "motor_torque 4 N·m" in out
    assert "fastest ratio change: not computed (--quick)" in out


@pytest.mark.slow
def test_api_gives_the_commands_json(tmp_path):
    from cvtdesign import api
    assert main(["transient", EXISTING, "--quick", "--gamma-to", "30 deg", "--bandwidth-at", "30 deg",
                 "--json", str(tmp_path / "t.json")]) == 0
    result = api.transient(EXISTING, gamma_to=30, bandwidth_at_deg=[30], quick=True)
    assert result.to_json() == (tmp_path / "t.json").read_text()
    table = result.table
    assert list(table["variant"]) == ["existing"] and table["f3dB_Hz"].iloc[0] == result.rows[0]["bandwidth_Hz"][0]["f3dB_Hz"]
    folder = result.plot(tmp_path / "figures")
    assert sorted(p.name for p in folder.iterdir()) == ["existing_bode.png", "existing_step.png"]


def _linear(poles) -> Linear:
    A = np.diag(np.asarray(poles, float))
    n = len(poles)
    return Linear(A, np.ones(n), np.zeros(n), {"gamma_axis": np.ones(n), "ratio": np.ones(n)}, np.diag(A))


def test_no_number_where_the_physics_stopped():
    """Each figure where the physics stopped holding is null with its reason, never a number."""
    rad = np.radians
    failed = uses.step_record(Step(None, None, None, None, None, False, "gross slip during the step"),
                              rad(10), rad(40), 0.5)
    assert [failed[k] for k in ("rise_s", "settle_s", "overshoot_pct", "lag_s")] == [None] * 4
    assert failed["reason"] == "gross slip during the step" and failed["ok"] is False
    unsettled = uses.step_record(Step(None, 0.01, None, 0.0, 0.02, True), rad(10), rad(40), 0.5)
    assert unsettled["settle_s"] is None and unsettled["reason"] == "not settled within the run"
    assert uses.rate_record(FastestChange(0.0, "no steady state at γ_from")) == {
        "max_rate_deg_s": None, "max_rate_limit": "no steady state at γ_from", "max_rate_reason": "no steady state at γ_from"}
    slid = uses.rate_record(FastestChange(0.0, "gross slip at N1"))
    assert slid["max_rate_deg_s"] is None and "slowest rate searched" in slid["max_rate_reason"]
    free = uses.rate_record(FastestChange(1e5, "none"))
    assert free["max_rate_deg_s"] is None and "fastest rate searched" in free["max_rate_reason"]
    assert uses.rate_record(FastestChange(91.5, "motor torque")) == {
        "max_rate_deg_s": 91.5, "max_rate_limit": "motor torque", "max_rate_reason": None}
    assert uses.bandwidth_record(None, rad(40), 0.5)["reason"] == "no steady state"
    unstable = uses.bandwidth_record(_linear([1.0, -5.0]), rad(40), 0.5)
    assert unstable["f3dB_Hz"] is None and unstable["ratio_f3dB_Hz"] is None and "unstable" in unstable["reason"]
    stable = uses.bandwidth_record(_linear([-2 * np.pi * 3.0]), rad(40), 0.5)      # a first-order lag at 3 Hz
    assert stable["f3dB_Hz"] == pytest.approx(3.0, rel=1e-6) and stable["reason"] is None
    from cvtdesign.io.strict_json import json_text
    assert '"f3dB_Hz": null' in json_text(unstable)


def test_a_run_beyond_the_physics_gives_nulls_with_reasons(tmp_path, capsys):
    """Kim's existing CVT stepped from 0° to 80° with shaft 2's torque of −1 N·m at 0° held has no steady state
    to end in: the step's figures are null with the reason, the bandwidths numbers, and the table marks the
    step's cells and says why."""
    argv = ["transient", EXISTING, "--quick", "--gamma-from", "0 deg", "--gamma-to", "80 deg", "--load", "-1 N*m",
            "--bandwidth-at", "0 deg", "--json", str(tmp_path / "t.json")]
    assert main(argv) == 0
    v = json.loads((tmp_path / "t.json").read_text())["variants"][0]
    step = v["step"]
    assert step["ok"] is False and step["reason"] and all(step[k] is None for k in STEP_KEYS if k.endswith(("_s", "_pct")))
    assert _number(v["bandwidth_Hz"][0]["f3dB_Hz"]) and v["bandwidth_Hz"][0]["reason"] is None
    out = " ".join(capsys.readouterr().out.split())
    assert f"¹ existing: no figure for step: {step['reason']}" in out
    assert "│ lag to 50 % [ms] │ — ¹ │" in out


def test_an_integration_that_cannot_go_on_is_a_reason():
    """CVODES stopping (the model's rates no longer finite) is the figure's reason, not a traceback; any other
    error is raised."""
    def stops():
        raise RuntimeError('Error in Function::call for \'transient\' [CvodesInterface]: CVode returned '
                           '"CV_REPTD_RHSFUNC_ERR". Consult CVODES documentation.')

    assert uses.integrated(stops) == (None, "the integration stopped: the model's rates were no longer finite "
                                            "(CVODES CV_REPTD_RHSFUNC_ERR)")
    assert uses.integrated(lambda x: 2 * x, 3) == (6, None)
    with pytest.raises(RuntimeError, match="other"):
        uses.integrated(lambda: (_ for _ in ()).throw(RuntimeError("other")))


def _variant_with(tmp_path, dynamics: str):
    text = (ROOT / "variants" / "box.yaml").read_text().replace("\neffects:", f"\ndynamics: {dynamics}\neffects:", 1)
    f = tmp_path / "dyn.yaml"
    f.write_text(text)
    return str(f)


@pytest.mark.parametrize("argv, words", [
    (["--gamma-to", "85 deg"], ["--gamma-to", "outside the envelope's γ range", "-80..80°"]),
    (["--gamma-from", "10"], ["--gamma-from", "did you mean '10 deg'"]),
    (["--gamma-from", "40 deg"], ["--gamma-to", "another γ"]),
    (["--bandwidth-at", "10 deg,x"], ["--bandwidth-at", "angle"]),
    (["--bandwidth-at", "10 deg,-85 deg"], ["--bandwidth-at", "outside the envelope's γ range"]),
    (["--load", "2 N*m"], ["--load", "outside the envelope's load range"]),
    (["--load", "1 m"], ["--load", "torque"]),
    (["--render-hz", "0"], ["--render-hz", "positive frequency"]),
    (["--render-hz", "-1"], ["--render-hz", "positive frequency"]),
    (["--render-hz", "nan"], ["--render-hz", "positive frequency"]),
])
def test_bad_option_is_one_line(tmp_path, capsys, argv, words):
    assert main(["transient", BOX, *argv, "--json", str(tmp_path / "t.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and all(w in err for w in words), err
    assert not (tmp_path / "t.json").exists()


@pytest.mark.parametrize("dynamics, words", [
    ("{motor_torque: -1 N*m}", ["dynamics.motor_torque", "expected a positive value"]),
    ("{servo_bandwidth: 20 rad/s}", ["dynamics.servo_bandwidth", "expected a frequency like '20 Hz'"]),
])
def test_bad_dynamics_value_is_one_line(tmp_path, capsys, dynamics, words):
    variant = _variant_with(tmp_path, dynamics)
    assert main(["transient", variant, "--quick", "--json", str(tmp_path / "t.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and variant in err and all(w in err for w in words), err
    assert not (tmp_path / "t.json").exists()


def test_a_given_motor_is_not_assumed(tmp_path):
    from cvtdesign.io.dynamics import dynamic_parameters
    from cvtdesign.io.variant import load_variant
    variant = _variant_with(tmp_path, "{motor_torque: 2 N*m, servo_bandwidth: 10 Hz}")
    p = uses.parameters_record(dynamic_parameters(load_variant(variant)))
    assert "motor_torque" not in p["assumed"] and "servo_bandwidth" not in p["assumed"] and "motor_speed" in p["assumed"]
    assert p["values"]["motor_torque"] == {"value": 2.0, "unit": "N·m", "source": "variant: dynamics.motor_torque"}
    assert p["values"]["servo_bandwidth"]["value"] == 10.0


@pytest.mark.slow
def test_both_machines_in_full(tmp_path, capsys):
    """The whole run on the box and Kim's existing CVT: every figure of the interface is a number, the limit
    named, the rendering's errors there, and the README shows what the command gives."""
    argv = ["transient", BOX, EXISTING, "--json", str(tmp_path / "t.json"), "--plots", str(tmp_path / "p")]
    assert main(argv) == 0
    out = capsys.readouterr().out
    rows = json.loads((tmp_path / "t.json").read_text())["variants"]
    readme = (ROOT / "README.md").read_text()
    for v in rows:
        assert _number(v["max_rate_deg_s"]) and v["max_rate_deg_s"] > 0
        assert v["max_rate_limit"] in ("motor torque", "motor speed") or v["max_rate_limit"].startswith("gross slip at")
        r = v["rendering"]
        assert r["reason"] is None and r["rms_error_dynamic"] <= r["max_error_dynamic"]
        from cvtdesign.cli.transient import _rate_cell
        assert _rate_cell(v) in out and _rate_cell(v) in readme, _rate_cell(v)
    assert (tmp_path / "p" / "box+existing_render.png").read_bytes().startswith(b"\x89PNG")


@pytest.mark.slow
def test_report_fits_any_width(quick_run, tmp_path):
    """The report (the table and both figures of a --quick run) fits 1280 and 700 pixels in a headless
    browser, its images decode."""
    from test_report import fits
    assert len(fits(quick_run / "t.html", tmp_path)) == 2
