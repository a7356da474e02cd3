"""`cvtdesign tolerance` samples the physical inputs (calibration, preload, moduli, friction, the law's own
error: core.inputs) beside the toleranced dimensions, in the same compiled call (issue 33): with the
tolerances at zero its spread is compare's interval; its ranking sets the inputs beside the dimensions with
the model's exact derivatives; `--dimensions-only` is today's study, draw for draw. Small envelopes (3 × 3
points)."""
from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from conftest import ROOT, variant_data, write_yaml
from cvtdesign.cli import main
from cvtdesign.core.inputs import physical_inputs, theta_inputs, uncertain_model
from cvtdesign.core.metrics import envelope, envelopes, metrics
from cvtdesign.core.tolerances import draw
from cvtdesign.core.uncertainty import checked_by_sampling, intervals, sampled_figures, spread
from cvtdesign.design import tolerance
from cvtdesign.design.tolerance import CHUNK, FIGURES, LINEAR_DRAWS, LINEAR_STREAM, built_model, tolerance_content
from cvtdesign.design.tolerance_inputs import model_arguments
from cvtdesign.design.tolerance_stats import derivatives, first_order

AXLES = ROOT / "tests" / "data" / "box_axle_tolerances.yaml"
SAMPLES = 400        # each end of a 95 % range to about 3.4 % of its width (1σ), in each of the two samplings


@pytest.fixture(scope="module")
def kalker(tmp_path_factory):
    d = variant_data("box")
    d["envelope"]["gamma"] = {"start": "-40 deg", "stop": "40 deg", "step": "40 deg"}
    d["envelope"]["load"] = {"start": "-1 N*m", "stop": "1 N*m", "step": "1 N*m"}
    return write_yaml(tmp_path_factory.mktemp("v") / "box_small.yaml", d)


@pytest.fixture(scope="module")
def zero(kalker):
    """The box's eight axles toleranced at σ 0 with every physical input sampled: compare's uncertainty alone."""
    c = tolerance_content(kalker, AXLES)
    return dataclasses.replace(c, dims=tuple(dataclasses.replace(d, size=0.0) for d in c.dims), digest="zero")


def rows_of(content, n):
    return [r for k in range(n // CHUNK) for r in tolerance.run_chunk(content, {"id": k, "chunk": k}, "")["rows"]]


def test_the_inputs_sampled_are_compares_and_a_toleranced_preload_is_not_counted_twice(kalker, tmp_path):
    """Every uncertain input of core.inputs, once per key, with its σ and compare's distribution; the
    variant's own preload is left out, with why, where the tolerances file tolerances every roller's preload
    (the same quantity), and kept where it tolerances some; --dimensions-only samples none."""
    c = tolerance_content(kalker, AXLES)
    L = c.layout
    want = theta_inputs(L, ["drive_longitudinal_creep.scale", "steering_lateral_creep.scale"]) + physical_inputs(L)
    assert [(s.key, s.std) for s in c.inputs] == [(i.key, i.std) for i in want]
    assert {s.kind for s in c.inputs} == {"calibration", "calibration_preload", "preload", "modulus", "friction", "spin"}
    assert all(s.distribution == ("uniform" if s.kind in ("friction", "spin") else "normal") for s in c.inputs)
    assert c.design_size == len(c.dims) + sum(not s.entries[0].in_theta for s in c.inputs)
    every = write_yaml(tmp_path / "p.yaml", {"name": "p", "seed": 0, "tolerances": [
        {"dimension": "preload", "rollers": "all", "uniform": "10 %"}]})
    some = write_yaml(tmp_path / "q.yaml", {"name": "q", "seed": 0, "tolerances": [
        {"dimension": "preload", "rollers": ["A"], "uniform": "10 %"}]})
    dropped = tolerance_content(kalker, every)
    assert "preload" not in [s.label for s in dropped.inputs] and "every roller's preload" in dict(dropped.left_out)["preload"]
    assert "preload" in [s.label for s in tolerance_content(kalker, some).inputs]
    only = tolerance_content(kalker, AXLES, dimensions_only=True)
    assert only.inputs == () and only.design_size == len(only.dims) and only.digest != c.digest


@pytest.mark.slow
def test_at_zero_tolerance_a_sample_is_compares_machine_at_the_same_inputs(zero):
    """With the dimensions at zero, each sample's figures are those of compare's uncertain model (core.inputs)
    at the sample's input deviations (its design inputs, and θ for the calibration) to 1e-9: the same
    machine, evaluated in the study's one call per chunk."""
    model, _ = built_model(zero)
    x = tolerance.chunk_draws(zero, 3)
    rows = tolerance.run_chunk(zero, {"id": "c", "chunk": 3}, "")["rows"]
    m = uncertain_model(zero.layout)
    design, theta = model_arguments(model, len(zero.dims), zero.inputs, x)
    assert theta is not None and np.ptp(theta, axis=0).max() > 0 and design.shape[1] == model.design.numel()
    for i, res in enumerate(envelopes(m, design[:, len(zero.dims):], theta)):
        want = metrics(m, res)
        assert rows[i]["status"] == "ok"
        for k in FIGURES:
            assert rows[i][k] == pytest.approx(want[k], rel=1e-9, abs=1e-12), k


@pytest.mark.slow
def test_at_zero_tolerance_the_spread_is_compares_interval(zero):
    """The tolerances at zero: the study's samples' 2.5–97.5 % range of each figure agrees with compare's
    interval as compare reports it (first order, checked by its own SAMPLES samples: core.uncertainty)
    within 15 % of its width (issue 33's bound; each end's sampling error is about 3.4 % of the width in
    each sampling, measured: at most 7 %), and the first order's σ (2000 draws of the linearised envelope,
    1.6 % noise) is compare's first-order σ within 5 % where the figure's extreme is one point's."""
    model, nominal = built_model(zero)
    rows = rows_of(zero, SAMPLES)
    assert all(r["status"] == "ok" for r in rows)
    m = uncertain_model(zero.layout)
    res = envelope(m)
    s = spread(m, res)
    row = metrics(m, res)
    row |= intervals(s, row)
    row |= checked_by_sampling(row, sampled_figures(m, SAMPLES))
    for k in FIGURES:
        lo, hi = row[f"{k}_interval"]
        got = np.percentile([r[k] for r in rows], [2.5, 97.5])
        assert np.all(np.abs(got - [lo, hi]) < 0.15 * (hi - lo)), (k, got, lo, hi)
    xs = np.array([[r[f"x.{c.label}"] for c in zero.sources] for r in rows])
    fo = first_order(model, nominal, zero, xs)
    for k in ("rms_alpha_deg", "max_traction_utilisation", "max_steering_torque_Nm"):
        assert np.std(fo["values"][:, FIGURES.index(k)]) == pytest.approx(s.sigma(k), rel=0.05), k


@pytest.mark.slow
def test_the_derivatives_in_each_input_are_exact(zero):
    """d(α)/d(input) of the ranking (a θ input through its θ entry, a design one through its column) against
    central differences of the envelope at the input's relative deviation ±1e-6: within 1e-4 of the largest."""
    model, nominal = built_model(zero)
    ok = np.flatnonzero(np.ravel(nominal["ok"]))
    d = derivatives(model, nominal, ok, zero)["alpha"]
    n_d = len(zero.dims)
    for k in (0, 3, len(zero.inputs) - 1):       # the drive calibration, the variant's preload, the law's error
        x = np.zeros((2, len(zero.sources)))
        x[:, n_d + k] = [1e-6, -1e-6]
        up, down = envelopes(model, *model_arguments(model, n_d, zero.inputs, x))
        fd = (np.ravel(up["alpha"]) - np.ravel(down["alpha"]))[ok] / 2e-6
        assert np.allclose(d[:, n_d + k], fd, rtol=0, atol=1e-4 * np.max(np.abs(d[:, n_d + k]))), zero.inputs[k].label


@pytest.mark.slow
def test_dimensions_only_is_todays_study_draw_for_draw(kalker):
    """--dimensions-only: the study's digest (its store), its model's design vector, its draws and each
    sample's figures are exactly today's: the dimensions from the seed sequence (seed, chunk), the model
    evaluated at them alone."""
    c = tolerance_content(kalker, AXLES, dimensions_only=True)
    model, nominal = built_model(c)
    assert model.design.numel() == len(c.dims)
    x = draw(c.dims, np.random.default_rng([c.seed, 2]), CHUNK)
    assert np.array_equal(tolerance.chunk_draws(c, 2), x)
    rows = tolerance.run_chunk(c, {"id": "c", "chunk": 2}, "")["rows"]
    for i, res in enumerate(envelopes(model, x)):
        want = tolerance.sample_row(model, nominal, c.dims, x[i], res)
        assert {k: rows[i][k] for k in want} == want
    fo = first_order(model, nominal, c, x)
    assert np.array_equal(fo["draws"], draw(c.dims, np.random.default_rng([c.seed, LINEAR_STREAM]), LINEAR_DRAWS))


@pytest.mark.slow
def test_the_command_ranks_the_inputs_beside_the_dimensions_and_says_which_it_sampled(kalker, tmp_path, capsys):
    """By default the JSON lists the inputs sampled (and those left out), each figure's effects rank the
    inputs beside the dimensions ({"input", "kind"} beside {"dimension"}), and the table names them; with
    --dimensions-only none is sampled and the table says so. On the box, the preloads (σ 20 %, assumed)
    matter more for max |α| than a 0.1° steering axle."""
    argv = ["tolerance", str(kalker), "--tolerances", str(AXLES), "--samples", "20", "--workers", "1"]
    assert main(argv + ["--json", str(tmp_path / "a.json"), "--store", str(tmp_path / "a")]) == 0
    text = " ".join(capsys.readouterr().out.split())
    out = json.loads((tmp_path / "a.json").read_text())
    assert [i["label"] for i in out["inputs"]][:3] == ["calibration (drive)", "calibration (steering)",
                                                       "preload (the calibration's machine, 100 N assumed)"]
    assert out["inputs_left_out"] == {}
    ranked = out["effects"]["max_abs_alpha_deg"]
    assert len(ranked) == len(out["dimensions"]) + len(out["inputs"])
    assert {e["kind"] for e in ranked if "input" in e} == {i["kind"] for i in out["inputs"]}
    assert ranked[0] == ranked[0] | {"input": "preload", "kind": "preload"}
    assert "physical inputs (law kalker)" in text and "│ input: preload │ σ 20 % (assumed) │" in text
    assert "physical inputs sampled with the dimensions" in text
    assert main(argv + ["--dimensions-only", "--json", str(tmp_path / "b.json"), "--store", str(tmp_path / "b")]) == 0
    assert "dimensions only (--dimensions-only)" in " ".join(capsys.readouterr().out.split())
    only = json.loads((tmp_path / "b.json").read_text())
    assert only["inputs"] == [] and all("dimension" in e for e in only["effects"]["max_abs_alpha_deg"])
