"""The dynamic model linearised at a steady state, from its exact Jacobians: the small-signal frequency response
of the transmission's axis angle γ_axis and of its speed ratio ω2/ω1 to the commanded γ, and the −3 dB bandwidth.

With δẊ = A δX + B0 δγ + B1 δγ̇ (the command enters through γ and the linkage's φ(γ), and through their rates in
the servo's rate term), H(jω) = C (jωI − A)⁻¹ (B0 + jω B1). The bandwidth f_3dB is the lowest frequency at which
|H(j2πf)| falls to |H(0)|/√2.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from cvtdesign.core.dynamics.model import DynamicModel
from cvtdesign.core.dynamics.response import command, linkage_slope, start
from cvtdesign.core.dynamics.simulate import simulate

F_SCAN = np.logspace(-2, 4, 241)    # [Hz] where the response is scanned for the first −3 dB crossing
SIGNALS = ("gamma_axis", "ratio")


@dataclass
class Linear:
    """A, B0, B1 and the output rows C of SIGNALS (a dict) at one steady state; `poles` the eigenvalues of A."""
    A: np.ndarray
    B0: np.ndarray
    B1: np.ndarray
    C: dict
    poles: np.ndarray

    @property
    def stable(self) -> bool:
        return bool(np.all(self.poles.real < 0))

    def response(self, signal: str, freqs_hz) -> np.ndarray:
        """H(j2πf) of `signal` per unit commanded γ (complex, [rad/rad] or [1/rad] for the ratio)."""
        n = self.A.shape[0]
        out = []
        for f in np.atleast_1d(freqs_hz):
            s = 2j * np.pi * f
            out.append(self.C[signal] @ np.linalg.solve(s * np.eye(n) - self.A, self.B0 + s * self.B1))
        return np.array(out)

    def bandwidth(self, signal: str) -> float | None:
        """f_3dB [Hz] of `signal`, None where the response stays above −3 dB over F_SCAN or A is unstable."""
        if not self.stable:
            return None
        g0 = abs(self.response(signal, [0.0])[0])
        mag = np.abs(self.response(signal, F_SCAN)) / g0
        below = np.nonzero(mag < 1 / np.sqrt(2))[0]
        if below.size == 0 or below[0] == 0:
            return None
        lo, hi = np.log(F_SCAN[below[0] - 1]), np.log(F_SCAN[below[0]])
        for _ in range(50):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if abs(self.response(signal, [np.exp(mid)])[0]) / g0 > 1 / np.sqrt(2) else (lo, mid)
        return float(np.exp(0.5 * (lo + hi)))


def linearise(model: DynamicModel, X: np.ndarray, u: np.ndarray, dphi_dgamma: float, theta=None) -> Linear:
    """The Linear model at steady state X under constant inputs u; dφ/dγ [-] of the linkage at that γ."""
    th = np.asarray(model.param_values if theta is None else theta, float)
    Xs, us = ca.MX.sym("X", X.size), ca.MX.sym("u", u.size)
    f = model.rhs(0, Xs, us, th)
    outs = dict(zip(model.outputs.name_out(), model.outputs.call([0, Xs, us, th])))
    fn = ca.Function("lin", [Xs, us], [ca.jacobian(f, Xs), ca.jacobian(f, us),
                                      *[ca.jacobian(outs[k], Xs) for k in SIGNALS]])
    A, Bu, *C = (np.array(v) for v in fn(X, u))
    B0 = Bu[:, 0] + Bu[:, 2] * dphi_dgamma
    B1 = Bu[:, 1] + Bu[:, 3] * dphi_dgamma
    return Linear(A, B0, B1, {k: c.ravel() for k, c in zip(SIGNALS, C)}, np.linalg.eigvals(A))


def linear_at(model: DynamicModel, gamma: float, load: float, load_is_tau_2: bool = False) -> Linear | None:
    """The Linear model at the steady state of command γ [rad] and load [N m], shaft 2's torque held
    (core.dynamics.response.start); None where there is no steady state."""
    X, tau2 = start(model, gamma, load, load_is_tau_2)
    u = command(model, gamma, tau2, load_is_tau_2=True)
    return None if X is None else linearise(model, X, u, linkage_slope(model, gamma))


def sine_gain(model: DynamicModel, gamma: float, load: float, freq_hz: float, signal: str = "gamma_axis",
              amplitude: float = 1e-3, periods: int = 8, pieces: int = 60) -> complex | None:
    """The gain of `signal` per unit commanded γ at freq_hz [Hz], measured in time: the command γ + A sin(2πft)
    (A = amplitude [rad], piecewise linear in `pieces` a period) from the steady state at γ, and the response's
    component at f fitted by least squares over the last two of `periods` periods. It checks the linear model's
    H(j2πf) (tests/unit/core/test_dynamics.py); None where there is no steady state at γ."""
    X, tau2 = start(model, gamma, load)
    if X is None:
        return None
    T = periods / freq_hz
    t = np.linspace(0.0, T, periods * pieces + 1)
    g = gamma + amplitude * np.sin(2 * np.pi * freq_hz * t)
    segs = [command(model, a, tau2, t0, (b - a) / (t1 - t0), True)
            for a, b, t0, t1 in zip(g[:-1], g[1:], t[:-1], t[1:])]
    tr = simulate(model, X, segs, T, periods * 4 * pieces)
    last = tr.t >= T - 2 / freq_hz
    w = 2 * np.pi * freq_hz * tr.t[last]
    basis = np.column_stack([np.sin(w), np.cos(w), np.ones_like(w)])
    (a, b, _), *_ = np.linalg.lstsq(basis, tr.out[signal][last], rcond=None)
    return complex(a, b) / amplitude
