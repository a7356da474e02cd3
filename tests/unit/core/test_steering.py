"""Steering effort (core.steering, core.equations.fork_terms): the torque to turn each fork while the contacts roll
and at standstill, and the steering motor's through the linkage; in compare's table, notes and JSON and in
`--points`."""
from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.special import ellipe

from conftest import shipped_model, variant_data, variant_path, write_yaml
from cvtdesign.core.metrics import envelope, envelopes, metrics
from cvtdesign.core.model import compile_model
from cvtdesign.core.steering import SAMPLE_NODES, sliding_lever, sliding_lever_expr, standstill_torques


@pytest.mark.parametrize("a, b", [(1e-3, 1e-3), (1.6e-3, 1e-3), (1e-3, 2.5e-3)])
def test_pivoting_patch_resists_with_the_pivot_lever(a, b):
    """Pure pivoting: (1/N)∫p|v|dA = ℓ = (3/8)·A·E(1 − B²/A²), A ≥ B the semi-axes (3πa/16 for a circle), here
    with SciPy's complete elliptic integral, not the package's; pure sliding gives the slide itself."""
    A, B = max(a, b), min(a, b)
    assert sliding_lever(a, b, 1.0, 0.0) == pytest.approx(0.375 * A * ellipe(1 - (B / A) ** 2), rel=1e-12)
    assert sliding_lever(a, b, -2.0, 0.0) == pytest.approx(2 * 0.375 * A * ellipe(1 - (B / A) ** 2), rel=1e-12)
    assert sliding_lever(a, b, 0.0, 0.03) == pytest.approx(0.03, rel=1e-12)


def test_sliding_lever_converges_where_the_slide_centre_is_inside_the_patch():
    """A slide whose instantaneous centre lies inside the patch (|s|/ω < a): |v| has a kink there, and the
    quadrature still converges (32 against 256 nodes: 2e-5), bounded by ℓω + |s| and above both apart."""
    a, b, w, s = 1.6e-3, 1e-3, 1.0, 0.5e-3
    coarse, fine = sliding_lever(a, b, w, s), sliding_lever(a, b, w, s, nodes=256)
    assert coarse == pytest.approx(fine, rel=2e-5)
    assert max(s, sliding_lever(a, b, w, 0.0)) < fine < s + sliding_lever(a, b, w, 0.0)


def test_samples_quadrature_is_within_its_stated_error():
    """Samples' envelopes take the standstill quadrature on SAMPLE_NODES (core.metrics.envelopes): within 3e-4 of
    the default's where the slide's centre lies inside the patch, 1e-6 outside it, and to round-off for pure
    pivoting; and the sampled figure of box_kim is `envelope`'s quadrature's to 1e-12."""
    a, b = 1.6e-3, 1e-3
    for w, s, rel in ((1.0, 0.5e-3, 3e-4), (1.0, 2.5e-3, 1e-6), (1.0, 0.0, 1e-13)):
        assert sliding_lever(a, b, w, s, SAMPLE_NODES) == pytest.approx(sliding_lever(a, b, w, s), rel=rel)
    model = shipped_model("box_kim")
    thetas = np.array(model.param_values) * np.array([[1.0], [1.02], [0.97]])
    for res in envelopes(model, np.zeros((3, 0)), thetas):
        full = standstill_torques(res, [r.fork_ratio for r in model.layout.rollers])[1]
        assert metrics(model, res)["max_standstill_steering_torque_Nm"] == pytest.approx(
            np.nanmax(np.where(res["ok"], full, np.nan)), rel=1e-12)


def test_standstill_at_a_pivoting_fork_is_mu_n_l():
    """Kim's forks turn about their contacts' normals, so at standstill each patch pivots: the fork's torque at
    one contact is μNℓ by hand (N, a, b of the point, ℓ from SciPy's E), to 1 %; the motor's is the sum over
    both forks (|k| = 1)."""
    model = shipped_model("existing_kim")
    res = envelope(model)
    names = [r.name for r in model.layout.rollers]
    i, k = names.index("S1"), 37
    N, a, b, mu = (np.asarray(res[q]).reshape(len(names), -1)[i, k] for q in ("N", "a", "b", "mu"))
    A, B = max(a, b), min(a, b)
    hand = mu * N * 0.375 * A * ellipe(1 - (B / A) ** 2)
    assert np.asarray(res["T_fork_standstill"]).reshape(len(names), -1)[i, k] == pytest.approx(hand, rel=0.01)
    forks = [j for j, r in enumerate(model.layout.rollers) if r.fork_axis is not None]
    per = np.asarray(res["T_fork_standstill"]).reshape(len(names), -1)[:, k]
    assert np.ravel(res["steering_torque_standstill"])[k] == pytest.approx(per[forks].sum(), rel=1e-12)
    assert np.all(per[[j for j in range(len(names)) if j not in forks]] == 0)


def test_rolling_torque_of_a_fork_through_its_contact_is_its_spin_moment():
    """With f = n the lateral force has no lever about the fork (n·(n × F) = 0) and the rolling resistance acts
    about the axle (n·a = 0): the fork's torque is the contact's spin moment, which Kim's law does not have
    (0 to round-off) and the kalker law does; the motor's is Σ k_i T_i."""
    for name, spins in (("existing_kim", False), ("existing", True)):
        model = shipped_model(name)
        res = envelope(model)
        rollers, n = model.layout.rollers, len(model.layout.rollers)
        T, M = (np.asarray(res[q]).reshape(n, -1) for q in ("T_fork", "M_spin"))
        ok = np.ravel(res["ok"])
        forks = [j for j, r in enumerate(rollers) if r.fork_axis is not None]
        np.testing.assert_allclose(T[forks][:, ok], M[forks][:, ok], rtol=0, atol=1e-12)
        motor = sum(rollers[j].fork_ratio * T[j] for j in forks)
        np.testing.assert_allclose(np.ravel(res["steering_torque"])[ok], motor[ok], rtol=0, atol=1e-12)
        assert (np.max(np.abs(motor[ok])) > 1e-3) == spins


@pytest.mark.slow
def test_compare_reports_steering_torque_and_where(tmp_path, cli):
    """compare's JSON: max_steering_torque_Nm and max_steering_torque_at (the interface outside tools read), the
    standstill figure and its place; the table's rows and the note saying where each extreme is taken."""
    d = variant_data("box")
    d["envelope"]["gamma"]["step"] = "40 deg"
    d["envelope"]["load"]["step"] = "0.5 N*m"
    code, out, _ = cli("compare", write_yaml(tmp_path / "b.yaml", d), "--out", tmp_path / "p",
                       "--json", tmp_path / "f.json")
    assert code == 0
    row = next(r for r in json.loads((tmp_path / "f.json").read_text())["variants"] if r["name"] == "box")
    assert row["max_steering_torque_Nm"] > 0.1 and row["max_standstill_steering_torque_Nm"] > 1.0
    at = row["max_steering_torque_at"]
    assert at["contact"] in {"N1", "N2", "S1", "S2"} and set(at) == {"gamma_deg", "tau_perp_Nm", "contact"}
    assert row["max_standstill_steering_torque_at"]["contact"] in {"N1", "N2", "S1", "S2"}
    assert "max steering torque [N·m]" in out and "steering at standstill [N·m]" in out
    flat = " ".join(out.split())
    assert f"box: where: max |α| at γ {row['max_abs_alpha_deg_at']['gamma_deg']:g}°" in flat
    assert f"max steering torque at {at['contact']}, γ {at['gamma_deg']:g}°" in flat


def _study(tmp_path, limit):
    data = {"name": "t", "base": str(variant_path("box_kim")), "multistart": {"starts": 1},
            "design": {"d": {"lower": "30 mm", "upper": "110 mm"}, "preload": {"lower": "40 N", "upper": "100 N"}},
            "envelope": {"gamma": {"start": "-60 deg", "stop": "60 deg", "step": "60 deg"},
                         "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "1 N*m"}},
            "constraints": {"max_steering_torque": limit}}
    return write_yaml(tmp_path / "study.yaml", data)


def test_optimise_rows_are_compares_steering_torques(tmp_path):
    """The optimiser's steering rows (CasADi, 12-node quadrature) at a design are compare's torques of the same
    design over the limit (rolling to 1e-9, standstill to 1e-6), and their derivative in the preload is the
    central difference's."""
    from cvtdesign.design.problem import build_problem
    from cvtdesign.design.study_file import load_study
    from cvtdesign.io.variant import load_variant
    pr = build_problem(load_study(_study(tmp_path, "4 N*m")))
    x = np.array([0.5, 0.5, 0.0])           # d 70 mm, preload 70 N (and the epigraph t)
    g = np.asarray(pr.evaluate(x)[1]).ravel()
    fam = np.array(pr.g_family)
    rolling = [i for i, lab in enumerate(pr.g_labels) if lab.startswith("rolling steering")]
    still = [i for i, lab in enumerate(pr.g_labels) if lab.startswith("standstill steering")]
    assert set(fam[rolling + still]) == {"steering_torque"} and len(rolling) == len(still) == 9
    d = variant_data("box_kim")
    d["parameters"]["d"], d["parameters"]["preload"] = "70 mm", "70 N"
    d["envelope"] = {"gamma": {"start": "-60 deg", "stop": "60 deg", "step": "60 deg"},
                     "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "1 N*m"}}
    model = compile_model(load_variant(write_yaml(tmp_path / "v.yaml", d)))
    res = envelope(model)
    np.testing.assert_allclose(g[rolling], np.ravel(res["steering_torque"]) / 4.0, rtol=0, atol=1e-9)
    np.testing.assert_allclose(g[still], np.ravel(res["steering_torque_standstill"]) / 4.0, rtol=1e-6)
    jac = np.asarray(pr.evaluate.factory("J", ["i0"], ["jac:o0:i0", "jac:o1:i0"])(x)[1])
    h = 1e-6
    fd = (np.asarray(pr.evaluate(x + [0, h, 0])[1]).ravel() - np.asarray(pr.evaluate(x - [0, h, 0])[1]).ravel()) / (2 * h)
    np.testing.assert_allclose(jac[still, 1], fd[still], rtol=1e-5)


def test_a_steering_motor_limit_is_met_by_the_preload(tmp_path):
    """The box with the preload free: without a limit the optimum keeps the largest preload; with 5 N·m it lowers
    the preload until the standstill row binds (to IPOPT's 1e-8), and slips more (d stays at the clearance's
    48.8 mm, where each fork needs μN·R sin θ = 0.0195 N·m per newton of preload: 5 N·m is 64 N)."""
    from cvtdesign.design.problem import build_problem
    from cvtdesign.design.study_file import load_study
    from cvtdesign.design.solve import solve_from, starts
    free_pr = build_problem(load_study(_study(tmp_path, None)))
    held_pr = build_problem(load_study(_study(tmp_path, "5 N*m")))
    free, held = solve_from(free_pr, starts(free_pr)[0]), solve_from(held_pr, starts(held_pr)[0])
    assert free.success and held.success
    assert free.design["preload"] == pytest.approx(100.0, rel=1e-6)
    assert held.objective > free.objective
    sin_theta = held.design["d"] / (2 * 0.0635)
    assert held.design["preload"] == pytest.approx(5.0 / (4 * 0.8 * 0.0635 * sin_theta), rel=0.01)
    still = [i for i, lab in enumerate(held_pr.g_labels) if lab.startswith("standstill steering")]
    assert np.max(held.g[still]) == pytest.approx(1.0, abs=1e-6)


def _full_circle_nodes(nodes: int):
    """The quadrature's nodes as they were first written: Gauss–Legendre in u, all 4·nodes angles of the
    trapezoid rule in t around the whole circle (core.steering._nodes folds them onto half of it)."""
    u, wu = np.polynomial.legendre.leggauss(nodes)
    u, wu = np.pi / 4 * (u + 1), np.pi / 4 * wu
    t = np.linspace(0.0, 2 * np.pi, 4 * nodes, endpoint=False)
    rho = np.sin(u)[:, None]
    weight = (wu * np.cos(u) ** 2 * np.sin(u))[:, None] * 3 / (4 * nodes) * np.ones_like(t)
    return rho * np.cos(t), rho * np.sin(t), weight


def _sliding_lever_loop(a, b, pivot, slide, nodes=32):
    """sliding_lever as it was written first, one patch at a time in a Python loop over the whole circle's
    nodes: the reference of its vectorised, folded form."""
    a, b, w, s = np.broadcast_arrays(*(np.asarray(v, float) for v in (a, b, pivot, slide)))
    xh, yh, weight = _full_circle_nodes(nodes)
    out = np.full(a.shape, np.nan)
    for k in zip(*np.nonzero(np.isfinite(a) & np.isfinite(b))) if a.ndim else [()]:
        x, y = a[k] * xh, b[k] * yh
        out[k] = np.sum(weight * np.hypot(w[k] * y, s[k] + w[k] * x))
    return out


def test_sliding_lever_vectorised_gives_the_loops_numbers():
    """The quadrature over every patch at once, on the nodes folded onto half the circle, gives the whole circle's
    loop's numbers to 1e-12 relative: pure pivoting, pure sliding, the slide's centre outside and inside the
    patch, both signs, a patch with no number (NaN stays NaN), a scalar, a 2-D array, more patches than one block
    (CHUNK_NODES), and the optimiser's expression (sliding_lever_expr, 12 nodes, its 1e-12 m smoothing aside)."""
    rng = np.random.default_rng(7)
    n = 3000
    a, b = rng.uniform(0.3e-3, 3e-3, n), rng.uniform(0.3e-3, 3e-3, n)
    w, s = rng.choice([-2.0, -1.0, 0.0, 0.5, 1.0], n), rng.normal(0.0, 2e-3, n) * rng.choice([0.0, 1.0], n)
    a[5], b[17] = np.nan, np.inf
    got, ref = sliding_lever(a, b, w, s), _sliding_lever_loop(a, b, w, s)
    assert np.array_equal(np.isnan(got), np.isnan(ref)) and np.isnan(got[[5, 17]]).all()
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=0)
    shaped = (a[:12].reshape(3, 4), b[:12].reshape(3, 4), w[:12].reshape(3, 4), 1e-4)
    np.testing.assert_allclose(sliding_lever(*shaped), _sliding_lever_loop(*shaped), rtol=1e-12, atol=0)
    for case in ((1e-3, 2e-3, 1.0, 0.0), (1.6e-3, 1e-3, 1.0, 0.5e-3), (1e-3, 1e-3, -1.0, 5e-3)):
        assert np.ndim(sliding_lever(*case)) == 0
        assert float(sliding_lever(*case)) == pytest.approx(float(_sliding_lever_loop(*case)), rel=1e-12)
    assert float(sliding_lever(1e-3, 1e-3, 1.0, 0.0, nodes=8)) == pytest.approx(
        float(_sliding_lever_loop(1e-3, 1e-3, 1.0, 0.0, nodes=8)), rel=1e-12)
    for case in ((1e-3, 2e-3, 1.0, 0.0), (1.6e-3, 1e-3, 1.0, 0.5e-3), (1e-3, 1e-3, -1.0, 5e-3)):
        assert float(sliding_lever_expr(*case)) == pytest.approx(float(_sliding_lever_loop(*case, nodes=12)), rel=1e-12)
