"""The dynamic model in time: its steady states and its response to a command, integrated by CasADi's CVODES
(BDF with Newton iterations on the model's exact Jacobian; no hand-written integrator).

A command is a list of segments, each starting at t0 with the commanded γ moving linearly (core.dynamics.model
INPUTS); the integrator restarts at each segment's start, so a step or a corner of a ramp is resolved exactly.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from cvtdesign.core.dynamics.model import OUTPUTS, DynamicModel
from cvtdesign.core.geometry import steering_angle_guess, steering_data

RTOL, ATOL = 1e-9, 1e-10      # CVODES tolerances on the scaled states
STEADY_TOL = 1e-12            # steady-state solve: the Newton iteration's tolerance on |Ẋ| of the scaled states
STEP_TOL = 1e-10              # a steady state is accepted where every row's residual over its largest Jacobian entry
                              # (its size in the states' units: the rows of a rigid direction are 1e9 times stiffer)
                              # is below this


@dataclass
class Trajectory:
    """A simulated response: times [s], states (states × times) and OUTPUTS (each times, or contacts × times)."""
    t: np.ndarray
    X: np.ndarray
    out: dict


def linkage_angle(model: DynamicModel, gamma) -> np.ndarray:
    """The linkage's angle φ [rad] that commands each γ [rad] (core.geometry's inverse kinematics)."""
    phi, _ = steering_angle_guess(*steering_data(model.layout), np.atleast_1d(np.asarray(gamma, float)))
    return phi


def steady_state(model: DynamicModel, u: np.ndarray, theta=None, start=None) -> np.ndarray | None:
    """The state at which Ẋ = 0 for constant inputs u (a segment with no rates), by Newton from the ideal
    kinematics (or `start`); None where the solve does not converge."""
    th = model.param_values if theta is None else theta
    solver, jac = _cached(model, "steady", lambda: _steady_functions(model, len(u), len(th)))
    x0 = model.steady_guess(u) if start is None else start
    pv = np.concatenate([u, th])
    x = np.array(solver(x0, pv)).ravel()
    J, resid = (np.array(v) for v in jac(x, pv))
    step = np.abs(resid.ravel()) / np.max(np.abs(J), axis=1)      # each row's residual in its states' units
    return x if np.all(np.isfinite(step)) and np.max(step) < STEP_TOL else None


def _steady_functions(model: DynamicModel, nu: int, nth: int) -> tuple[ca.Function, ca.Function]:
    """(Newton's rootfinder of Ẋ(X; [u, θ]) = 0, (X, [u, θ]) → (∂Ẋ/∂X, Ẋ)), built once a model."""
    X, p = ca.MX.sym("X", model.n_states), ca.MX.sym("p", nu + nth)
    f = ca.Function("g", [X, p], [model.rhs(0, X, p[:nu], p[nu:])])
    solver = ca.rootfinder("steady", "newton", f, {"abstol": STEADY_TOL, "abstolStep": 1e-14, "max_iter": 60,
                                                   "error_on_fail": False, "show_eval_warnings": False})
    return solver, ca.Function("j", [X, p], [ca.jacobian(f(X, p), X), f(X, p)])


def simulate(model: DynamicModel, X0: np.ndarray, segments: list, t_end: float, n_points: int = 400,
             theta=None) -> Trajectory:
    """Integrate from state X0 at the first segment's start to t_end [s]: `segments` is a list of INPUTS
    vectors (model.inputs), each holding from its own t0 to the next one's. The outputs are sampled at every
    segment's start and on about n_points times over the run, evenly within each segment."""
    th = np.asarray(model.param_values if theta is None else theta, float)
    starts = [float(s[4]) for s in segments] + [t_end]
    span = starts[-1] - starts[0]
    times, Xs, x = [starts[0]], [np.asarray(X0, float)], np.asarray(X0, float)
    for k, seg in enumerate(segments):
        h = starts[k + 1] - starts[k]
        if h <= 0:
            continue
        K = int(max(1, min(n_points, np.ceil(n_points * h / span))))
        xs = np.array(_integrator(model, K)(x0=x, p=np.concatenate([seg, th, [starts[k], h]]))["xf"])
        Xs.extend(xs.T)
        times.extend(starts[k] + h * np.arange(1, K + 1) / K)
        x = xs[:, -1]
    times, X = np.array(times), np.array(Xs).T
    us = np.array([segments[max(0, np.searchsorted(starts[:-1], t, side="left") - 1)] for t in times]).T
    return Trajectory(times, X, outputs_at(model, times, X, us, th))


def outputs_at(model: DynamicModel, times, X, us, theta) -> dict:
    """OUTPUTS at each time (columns of X and of the inputs us)."""
    n = len(times)
    f = _cached(model, ("outputs", n), lambda: model.outputs.map(n))
    got = f(np.atleast_2d(times), X, us, np.tile(np.asarray(theta, float)[:, None], (1, n)))
    return {k: (np.array(v)[0] if np.array(v).shape[0] == 1 else np.array(v)) for k, v in zip(OUTPUTS, got)}


def _integrator(model: DynamicModel, K: int) -> ca.Function:
    """CVODES over one segment, in its own time τ = (t − t_start)/h ∈ [0, 1] with K outputs evenly spaced, for
    parameters [INPUTS, θ, t_start, h]: one integrator serves every segment of any length."""
    def build():
        tau = ca.MX.sym("tau")
        X = ca.MX.sym("X", model.n_states)
        nu, nth = model.rhs.size1_in(2), model.rhs.size1_in(3)
        p = ca.MX.sym("p", nu + nth + 2)
        t_start, h = p[nu + nth], p[nu + nth + 1]
        dae = {"t": tau, "x": X, "p": p, "ode": h * model.rhs(t_start + h * tau, X, p[:nu], p[nu:nu + nth])}
        return ca.integrator("transient", "cvodes", dae, 0.0, list(np.arange(1, K + 1) / K),
                             {"abstol": ATOL, "reltol": RTOL, "max_num_steps": 200000,
                              "disable_internal_warnings": True, "show_eval_warnings": False})
    return _cached(model, ("integrator", K), build)


def _cached(model: DynamicModel, key, build):
    cache = model.__dict__.setdefault("_cache", {})
    if key not in cache:
        cache[key] = build()
    return cache[key]
