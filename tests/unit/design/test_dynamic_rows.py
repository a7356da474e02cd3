"""constraints.min_bandwidth_Hz and constraints.min_ratio_rate_deg_s (design/dynamic_rows.py): the dynamic
model's rows in a study's NLP, against the dynamic model itself (core.dynamics) and with derivatives the
optimiser can trust."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
import yaml

from conftest import ROOT, shipped_layout
from cvtdesign.core.dynamics.linear import linear_at
from cvtdesign.core.dynamics.model import compile_dynamics
from cvtdesign.design.problem import build_problem
from cvtdesign.design.solve import solve_from, starts
from cvtdesign.design.study_file import load_study
from cvtdesign.errors import InputError
from cvtdesign.io.dynamics import dynamic_parameters


def study(tmp_path, name="box_placement_kim", **constraints):
    data = yaml.safe_load((ROOT / "studies" / f"{name}.yaml").read_text())
    data["base"] = str((ROOT / "studies" / data["base"]).resolve())
    data["constraints"].update(constraints)
    path = tmp_path / "study.yaml"
    path.write_text(yaml.safe_dump(data))
    return load_study(path)


def rows_at_base(pr, family):
    z = (pr.base_values - pr.lower) / (pr.upper - pr.lower)
    x = np.append(z, 4.0) if pr.epigraph else z
    g = np.asarray(pr.evaluate(x)[1]).ravel()
    mask = np.array([f == family for f in pr.g_family])
    return x, g[mask], [lab for lab, m in zip(pr.g_labels, mask) if m]


def test_bandwidth_row_is_the_linear_models_bandwidth(tmp_path):
    """At the base design the row at γ = 40° changes sign where f_min crosses the linear model's f_3dB there."""
    layout = shipped_layout("box_kim")
    f3 = linear_at(compile_dynamics(layout, dynamic_parameters(layout)), np.radians(40), 1.0).bandwidth("gamma_axis")
    for factor, sign in ((0.99, 1), (1.01, -1)):
        _, g, labels = rows_at_base(build_problem(study(tmp_path, min_bandwidth_Hz=float(factor * f3))), "bandwidth")
        at40 = [v for v, lab in zip(g, labels) if "γ=+40°" in lab]
        assert len(at40) == 1 and np.sign(at40[0]) == sign


@pytest.mark.slow
def test_dynamic_rows_derivatives_are_exact(tmp_path):
    """Under Kim's law (no creep-force table) the rows' derivatives are exact: central differences agree, to
    their own error (step 1e-4 of the normalised design: truncation 1e-8, the inner Newton solves' round-off
    1e-5 absolute; at step 1e-6 the round-off reaches 1e-3)."""
    pr = build_problem(study(tmp_path, min_bandwidth_Hz=8.0, min_ratio_rate_deg_s=50.0))
    mask = [i for i, f in enumerate(pr.g_family) if f in ("bandwidth", "ratio_rate")]
    assert len(mask) == 5 + 5 * 2 * (2 + 8)
    g = ca.vertcat(*[pr.parts.g_full[i] for i in mask])
    F = ca.Function("F", [pr.parts.x], [g, ca.jacobian(g, pr.parts.x)])
    x, *_ = rows_at_base(pr, "bandwidth")
    _, J = F(x)
    h = 1e-4
    for k in range(len(pr.names)):
        e = np.zeros_like(x)
        e[k] = h
        fd = (np.asarray(F(x + e)[0]) - np.asarray(F(x - e)[0])).ravel() / (2 * h)
        np.testing.assert_allclose(np.asarray(J)[:, k], fd, rtol=1e-3, atol=1e-4)


@pytest.mark.parametrize("field, value, words", [
    ("min_bandwidth_Hz", -2, "constraints.min_bandwidth_Hz"),
    ("min_bandwidth_Hz", "20 rad/s", "constraints.min_bandwidth_Hz"),
    ("min_ratio_rate_deg_s", "3 Hz", "constraints.min_ratio_rate_deg_s"),
    ("min_ratio_rate_deg_s", 0, "constraints.min_ratio_rate_deg_s"),
])
def test_bad_dynamic_constraints_are_one_line(tmp_path, field, value, words):
    with pytest.raises(InputError, match=words):
        build_problem(study(tmp_path, **{field: value}))


def test_dynamic_gamma_outside_the_envelope_is_one_line(tmp_path):
    with pytest.raises(InputError, match=r"constraints.dynamic_gamma\[1\]: expected an angle within the envelope"):
        build_problem(study(tmp_path, min_bandwidth_Hz=5.0, dynamic_gamma=["10 deg", "95 deg"]))


@pytest.mark.slow
def test_dynamic_gamma_chooses_the_points(tmp_path):
    pr = build_problem(study(tmp_path, min_bandwidth_Hz=5.0, dynamic_gamma=["-20 deg", "30 deg"]))
    labels = [lab for lab, f in zip(pr.g_labels, pr.g_family) if f == "bandwidth"]
    assert labels == ["bandwidth ≥ 5 Hz at γ=-20° τ⊥=+1", "bandwidth ≥ 5 Hz at γ=+30° τ⊥=+1"]


@pytest.mark.slow
def test_bandwidth_constraint_binds_and_costs_slip():
    """studies/box_bandwidth.yaml: the 10 Hz bandwidth binds at γ = 0 and costs slip against the placement optimum
    without it; the README's figures are these, and the written optimum's linear model meets 10 Hz."""
    pr = build_problem(load_study(ROOT / "studies" / "box_bandwidth.yaml"))
    sol = solve_from(pr, starts(pr)[0])
    band = np.array([f == "bandwidth" for f in pr.g_family])
    assert np.min(sol.g[band]) == pytest.approx(0.0, abs=1e-6)
    free = build_problem(load_study(ROOT / "studies" / "box_placement.yaml"))
    base = solve_from(free, starts(free)[0])
    assert sol.objective > base.objective + 0.03
    readme = (ROOT / "README.md").read_text()
    assert f"worst |α| {sol.objective:.4g}° against {base.objective:.4g}°" in readme
