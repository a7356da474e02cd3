"""Intervals on compare's figures from every uncertain input (core.inputs, core.uncertainty): the first-order
propagation uses the model's exact derivatives (checked against central differences of the figures), the
budgets sum to one and name the preload, a calibration absorbs the assumptions it was fitted under on the
machine it was fitted to and not on another, and the sampled check replaces an interval the first order
does not hold for."""
from __future__ import annotations

import numpy as np
import pytest

from conftest import shipped_model, variant_data, write_yaml
from cvtdesign.core import uncertainty
from cvtdesign.core.inputs import model_inputs, uncertain_model
from cvtdesign.core.metrics import envelope, metrics
from cvtdesign.io.variant import load_variant


def coarse(tmp_path, name, edit=None, file="v"):
    """A shipped variant on a coarse envelope (γ step 40°, load step 0.5 N·m: 25 points), edited."""
    d = variant_data(name)
    d["envelope"]["gamma"]["step"] = "40 deg"
    d["envelope"]["load"]["step"] = "0.5 N*m"
    if edit:
        edit(d)
    return load_variant(write_yaml(tmp_path / f"{file}.yaml", d))


def central_differences(model, inputs, keys, h):
    """d figure / d input by central differences of the figures themselves, θ inputs on θ, others on design."""
    th0, x0 = np.asarray(model.param_values, float), np.zeros(model.design.numel())
    out, j_design = {k: [] for k in keys}, 0
    for inp in inputs:
        th_p, th_m, x_p, x_m = th0.copy(), th0.copy(), x0.copy(), x0.copy()
        if inp.in_theta:
            i = model.param_names.index(inp.target)
            th_p[i] += h
            th_m[i] -= h
        else:
            x_p[j_design] += h
            x_m[j_design] -= h
            j_design += 1
        up = metrics(model, envelope(model, theta=th_p, design=x_p))
        down = metrics(model, envelope(model, theta=th_m, design=x_m))
        for k in keys:
            out[k].append((up[k] - down[k]) / (2 * h))
    return {k: np.array(v) for k, v in out.items()}


@pytest.mark.parametrize("name", ["existing_kim", "existing"])
def test_figure_gradients_are_the_figures_derivatives(name, tmp_path):
    """d figure/d input of every figure in every input (calibration, preloads, moduli, friction, the law's spin
    error), against central differences (h = 1e-6) of the figure as compare computes it: relative error below
    1e-4 of the largest derivative (measured: 1e-8 under kim, 1e-6 under kalker, whose Newton solve stops at
    1e-10)."""
    model = uncertain_model(coarse(tmp_path, name))
    res = envelope(model)
    row = metrics(model, res)
    inputs = model_inputs(model)
    kinds = {i.kind for i in inputs}
    assert {"calibration", "calibration_preload", "modulus", "friction"} <= kinds
    assert ("spin" in kinds) == (name == "existing")          # Kim's law has no spin moment to be wrong about
    grads = uncertainty.figure_gradients(model, res, inputs)
    keys = [k for k in grads if row[k] is not None]
    assert {"max_abs_alpha_deg", "rms_alpha_deg", "ratio_error_pct_at_max_load", "min_efficiency"} <= set(keys)
    fd = central_differences(model, inputs, keys, 1e-6)
    for k in keys:
        scale = max(np.max(np.abs(fd[k])), 1e-3 * max(abs(row[k]), 1e-9))
        np.testing.assert_allclose(grads[k], fd[k], rtol=0, atol=1e-4 * scale, err_msg=k)


def test_budgets_sum_to_one_and_name_the_preload(tmp_path):
    """Every figure's budget: shares that sum to 1, over inputs that include a preload (the layout's own or the
    calibration machine's), the moduli and the pairs' friction."""
    model = uncertain_model(coarse(tmp_path, "box"))
    res = envelope(model)
    row = metrics(model, res)
    out = uncertainty.intervals(uncertainty.spread(model, res), row)
    budgets = {k.removesuffix("_budget"): v for k, v in out.items() if k.endswith("_budget")}
    assert {"max_abs_alpha_deg", "min_efficiency", "max_loss_no_output_W"} <= set(budgets)
    for figure, budget in budgets.items():
        assert sum(budget.values()) == pytest.approx(1.0, abs=1e-12), figure
        assert any(label.startswith("preload") for label in budget), figure
        assert any(label.startswith("modulus") for label in budget) and any(label.startswith("friction")
                                                                            for label in budget), figure


def test_a_calibration_absorbs_its_own_assumptions_and_not_anothers(tmp_path):
    """On Kim's machine at the preload his calibration was fitted at, the preload and the urethanes' moduli
    cancel in the creep (the fit holds the measured compliance): max |α|'s interval is a few percent wide. The
    same machine at 150 N is another machine: its preload is its own, and the interval is several times wider."""
    def half_width(L):
        model = uncertain_model(L)
        res = envelope(model)
        row = metrics(model, res)
        lo, hi = uncertainty.intervals(uncertainty.spread(model, res), row)["max_abs_alpha_deg_interval"]
        return (hi - lo) / 2 / row["max_abs_alpha_deg"]
    kims = half_width(coarse(tmp_path, "existing"))
    other = half_width(coarse(tmp_path, "existing", lambda d: d["parameters"].update(preload="150 N"), "p150"))
    assert kims < 0.06 and other > 2 * kims, (kims, other)


@pytest.mark.slow
def test_sampling_checks_every_interval(tmp_path):
    """The sampled check of compare (core.uncertainty.checked_by_sampling): each reported interval's ends lie
    within 15 % of its width of the 2.5–97.5 % range of an independent set of 400 samples (another seed), or the
    figure is said to have left the physics in some samples. A first-order interval that the samples do not
    confirm is replaced (worst efficiency: its first order crosses 0, an efficiency cannot)."""
    model = uncertain_model(coarse(tmp_path, "box"))
    res = envelope(model)
    row = metrics(model, res)
    row |= uncertainty.intervals(uncertainty.spread(model, res), row)
    first_order = dict(row)
    row |= uncertainty.checked_by_sampling(row, uncertainty.sampled_figures(model, 128, seed=1))
    check = uncertainty.sampled_figures(model, 400, seed=2)
    for key in [k.removesuffix("_interval") for k in row if k.endswith("_interval")]:
        if row[f"{key}_interval"] is None:
            continue
        values = np.array([s[key] for s in check if s.get(key) is not None])
        lo, hi = row[f"{key}_interval"]
        s_lo, s_hi = np.percentile(values, [2.5, 97.5])
        assert max(abs(s_lo - lo), abs(s_hi - hi)) <= 0.15 * max(hi - lo, s_hi - s_lo), (key, (lo, hi), (s_lo, s_hi))
    if first_order["min_efficiency_interval"][0] < 0:
        assert row["min_efficiency_interval"][0] >= 0 and row["min_efficiency_interval_method"].startswith("sampled")


def test_fitted_effect_parameters_widen_the_interval(tmp_path):
    """A fitted effect parameter with its σ (effect_uncertainty, as diagnose reports it) adds its own part to the
    worst efficiency's variance: (g σ)², independent of the other inputs."""
    def edit(d, sigma=None):
        d["effects"] = d["effects"] + ["rolling_resistance"]
        d["effect_parameters"] = {"rolling_resistance": {"offset": "0.2 mm"}}
        if sigma:
            d["effect_uncertainty"] = {"rolling_resistance": {"offset": sigma}}
    plain = uncertain_model(coarse(tmp_path, "existing_kim", edit, "a"))
    fitted = uncertain_model(coarse(tmp_path, "existing_kim", lambda d: edit(d, "0.05 mm"), "b"))
    res = envelope(plain)
    a, b = uncertainty.spread(plain, res), uncertainty.spread(fitted, envelope(fitted))
    key = next(k for k in b.std if k.endswith("rolling_resistance.offset"))
    g = b.gradients["min_efficiency"][key]
    assert b.sigma("min_efficiency") ** 2 == pytest.approx(a.sigma("min_efficiency") ** 2 + (g * 0.05e-3) ** 2,
                                                           rel=1e-6)
    assert b.sigma("min_efficiency") > 1.01 * a.sigma("min_efficiency")


def test_the_figures_bands_are_the_points_intervals(tmp_path):
    """The compare figure's band at the point where max |α| is taken is that figure's first-order interval (one
    computation, two views)."""
    model = uncertain_model(coarse(tmp_path, "existing_kim"))
    res = envelope(model)
    row = metrics(model, res)
    bands = uncertainty.point_bands(model, res)
    lo, hi = uncertainty.intervals(uncertainty.spread(model, res), row)["max_abs_alpha_deg_interval"]
    k = np.nanargmax(np.abs(res["alpha"]))
    assert np.degrees(bands["alpha_band"].ravel()[k]) == pytest.approx((hi - lo) / 2, rel=1e-9)


def test_a_plain_model_keeps_its_calibration_interval():
    """A model compiled without the physical inputs (as a study's) has the calibration's θ inputs alone: the
    robust study's covariance is theirs (1.3 % and 1.0 %, independent: two library entries)."""
    idx, cov = uncertainty.covariance(shipped_model("existing_kim"))
    assert len(idx) == 2 and np.sqrt(np.diag(cov)) == pytest.approx([0.013, 0.010]) and cov[0, 1] == 0
