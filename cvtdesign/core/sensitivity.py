"""Exact derivatives of a model's outputs in its effect parameters θ and design inputs at solved operating
points, by the implicit function theorem written out once, with no Newton solve inside.

At a root x of the model's residual F(x, q) = 0 (core.model: q = [γ_cmd, ω1, load, load_is_τ2, φ, θ, design]),

    dx/dc = −(∂F/∂x)⁻¹ ∂F/∂q · dq/dc,     d out/dc = ∂out/∂q · dq/dc + ∂out/∂x · dx/dc,

for the columns c asked for (entries of θ and of the design vector). dq/dc is 1 at the column's own entry
and, for a design column, also dφ/dc = −(∂r/∂φ)⁻¹ ∂r/∂c at φ, r the linkage's steering residual (the
steering angle moves with a design that moves the linkage). These are the numbers CasADi's rootfinder gives
when the point function is differentiated (its implicit derivatives), but the points are solved once (the
point function's `root` output: x and q) and the derivative function of (x, q) is mapped over them: a
fraction of the cost of differentiating the whole point function, whose interpreted Newton solve is
repeated in every evaluation of its Jacobian.
"""
from __future__ import annotations

import hashlib

import casadi as ca
import numpy as np

from cvtdesign.core.model import CONTACT_OUTPUTS, POINT_OUTPUTS, call_mapped

OUTPUT_NAMES = POINT_OUTPUTS + CONTACT_OUTPUTS    # the outputs of CompiledModel.outputs, in order

FIRST_THETA = 5          # q's entries before θ: γ_cmd, ω1, load, load_is_τ2, φ
PHI = 4                  # q's entry of the steering angle
LOAD = 2                 # q's entry of the load


def derivative_function(model, outputs: list[str], theta_cols: list[int], design_cols: list[int],
                        load: bool = False) -> ca.Function:
    """(x, q) → the parts of d output/d(θ[theta_cols], design[design_cols], then the load if asked) at a root
    x of the model at q
    (module docstring): ∂F/∂x, ∂F/∂q·dq/dc, ∂y/∂x and ∂y/∂q·dq/dc, y the named outputs stacked; `at_points`
    solves and combines them. The linear solve is left to LAPACK (partial pivoting): CasADi's symbolic one,
    unpivoted, lost 2 % of a derivative where the normal forces follow the force balance (cond 2e8)."""
    nx, nq = model.residual.size1_in(0), model.residual.size1_in(1)
    n_th = len(model.param_names)
    # in scalar operations (SX) where nothing calls compiled code (Kim's law): several times faster
    sym = ca.SX if model.residual.is_a("SXFunction") and model.outputs.is_a("SXFunction") else ca.MX
    x, q = sym.sym("x", nx), sym.sym("q", nq)
    cols = [FIRST_THETA + j for j in theta_cols] + [FIRST_THETA + n_th + j for j in design_cols] + [LOAD] * load
    dq = ca.DM.zeros(nq, len(cols))
    for k, c in enumerate(cols):
        dq[c, k] = 1.0
    dq = sym(dq)
    if design_cols:                       # the steering angle's own dependence on the design (none on the load)
        jr = ca.jacobian(model.steering_residual(q[PHI], ca.vertcat(q[0], q[FIRST_THETA + n_th:])), q)
        dphi = -jr[:, cols[len(theta_cols):]] / jr[:, PHI]
        dq += ca.vertcat(sym(PHI, len(cols)), ca.horzcat(sym(1, len(theta_cols)), dphi), sym(nq - PHI - 1, len(cols)))
    F = model.residual(x, q)
    every = dict(zip(OUTPUT_NAMES, model.outputs(x, q)))
    y = ca.vertcat(*(ca.vec(every[k]) for k in outputs))
    return ca.Function("sensitivity", [x, q], [ca.vec(ca.densify(v)) for v in (      # column by column
        ca.jacobian(F, x), ca.mtimes(ca.jacobian(F, q), dq), ca.jacobian(y, x), ca.mtimes(ca.jacobian(y, q), dq))],
        ["x", "q"], ["F_x", "F_c", "y_x", "y_c"])


def at_points(mapped: ca.Function, X: np.ndarray, Q: np.ndarray, sizes: list[int]) -> list[np.ndarray]:
    """d output/d(columns) at the points whose roots are the columns of X and Q: derivative_function `mapped`
    over them, dx = −(∂F/∂x)⁻¹ ∂F/∂c point by point, then ∂y/∂c + ∂y/∂x dx; per output (its `sizes`: rows) an
    array (rows, points, columns)."""
    n, nx = X.shape[1], X.shape[0]
    F_x, F_c, y_x, y_c = (v.T.reshape(n, -1, rows).transpose(0, 2, 1) for v, rows in       # (points, rows, cols)
                          zip(call_mapped(mapped, [X.T, Q.T]), (nx, nx, sum(sizes), sum(sizes))))
    d = y_c - y_x @ np.linalg.solve(F_x, F_c)
    edges = np.cumsum([0] + list(sizes))
    return [d[:, a:b, :].transpose(1, 0, 2) for a, b in zip(edges[:-1], edges[1:])]


def derivatives(model, gammas, speeds, loads, phi_guess, outputs: list[str], theta_cols: list[int],
                design_cols: list[int], load: bool = False) -> list[np.ndarray]:
    """d output/d(columns) at each point (γ_cmd, ω1, τ⊥ load, φ guess: vectors), at the model's θ and design 0,
    the load's column last where `load` (a capacity's interval, core.capacity_interval):
    per output an array (rows, points, columns); the points are solved by the model's `root` output (`roots`),
    then derivative_function is mapped over them on two threads (at_points)."""
    n = np.size(gammas)
    key = ("derivatives", tuple(outputs), tuple(theta_cols), tuple(design_cols), load, n)
    if key not in model._maps:
        model._maps[key] = derivative_function(model, outputs, theta_cols, design_cols, load).map(n, "thread", 2)
    X, Q = roots(model, gammas, speeds, loads, phi_guess)
    return at_points(model._maps[key], X, Q, output_sizes(model, outputs))


def roots(model, gammas, speeds, loads, phi_guess) -> tuple[np.ndarray, np.ndarray]:
    """The solutions x and parameters q (columns) of the points, at the model's θ and design 0: the point
    function's `root` output (its Newton solve, interpreted), solved once a model and set of points (a layout's
    figures' gradients and its plot's bands ask for derivatives at the same points)."""
    n = np.size(gammas)
    args = [gammas, speeds, loads, np.zeros(n), phi_guess, model.param_values, np.zeros(model.design.numel())]
    key = ("roots", n, hashlib.sha256(b"|".join(np.asarray(a, float).tobytes() for a in args)).hexdigest())
    if key not in model._maps:
        if ("root", n) not in model._maps:
            model._maps["root", n] = model.point_function(["root"]).map(n, "thread", 2)
        xq = call_mapped(model._maps["root", n], args)[0]
        nx = model.residual.size1_in(0)
        model._maps[key] = (xq[:nx], xq[nx:])
    return model._maps[key]


def output_sizes(model, outputs: list[str]) -> list[int]:
    """The number of rows of each named output of the model (1, or one per contact)."""
    return [len(model.roller_names) if k in CONTACT_OUTPUTS else 1 for k in outputs]
