"""Rendering a constraint: a cobot moving along a curve at a given speed commands a ratio that changes in time;
how far the transmission's ratio falls behind it, and how much of that the quasi-static model already predicts.

The profile: a cobot tracing a sine-shaped path y = A sin(2πx/λ) at a steady speed v along x commands the ratio
ẏ/ẋ = (2πA/λ) cos(2πvt/λ), a sinusoid at f = v/λ. Here its ratio swings between the ideal ratios of two commanded
angles, ρ_cmd(t) = ρ_m − ρ_a cos(2π f t) (it starts at the first), and γ_cmd(t) is the ideal law inverted
(core.kinematics.ShaftFrame.command_for_ratio), piecewise linear in time.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cvtdesign.core.dynamics.model import DynamicModel
from cvtdesign.core.dynamics.response import SAT_LIMIT, command, start
from cvtdesign.core.dynamics.simulate import simulate, steady_state

PIECES = 60          # linear pieces of the command per period
PERIODS = 2          # periods simulated; the errors are taken over the last one


@dataclass
class Rendering:
    """A rendered profile: times [s], the commanded ratio and the dynamic and quasi-static ratios [-] at each,
    the RMS and largest errors of each over the last period, and `ok` False (with `reason`) where a contact
    slid grossly or a quasi-static point had no steady state."""
    t: np.ndarray
    commanded: np.ndarray
    dynamic: np.ndarray
    quasi_static: np.ndarray
    rms_dynamic: float
    max_dynamic: float
    rms_quasi_static: float
    max_quasi_static: float
    ok: bool
    reason: str = ""


def render(model: DynamicModel, gamma_from, gamma_to, load, frequency_hz, load_is_tau_2=False) -> Rendering:
    """The ratio error while the commanded ratio swings between the ideal ratios at γ_from and γ_to [rad] at
    frequency_hz [Hz] from the load [N m] at the start, shaft 2's torque then held (module docstring)."""
    frame = model.layout_frame
    r0, r1 = (float(frame.ideal_ratio(g)) for g in (gamma_from, gamma_to))
    period = 1.0 / frequency_hz
    times = np.linspace(0.0, PERIODS * period, PERIODS * PIECES + 1)
    rho = 0.5 * (r0 + r1) - 0.5 * (r1 - r0) * np.cos(2 * np.pi * frequency_hz * times)
    gam = np.array([float(frame.command_for_ratio(r)) for r in rho])
    x0, tau2 = start(model, gam[0], load, load_is_tau_2)
    if x0 is None:
        return _failed(times, rho, "no steady state at the profile's start")
    segs = [command(model, g, tau2, t, (g1 - g) / (t1 - t), True)
            for g, g1, t, t1 in zip(gam[:-1], gam[1:], times[:-1], times[1:])]
    tr = simulate(model, x0, segs, times[-1], 8 * PIECES * PERIODS)
    quasi = np.array([_steady_ratio(model, g, tau2) for g in gam])
    dyn = np.interp(times, tr.t, tr.out["ratio"])
    if np.nanmax(tr.out["utilisation"]) >= SAT_LIMIT:
        return _failed(times, rho, "gross slip while rendering")
    if not np.all(np.isfinite(quasi)):
        return _failed(times, rho, "no steady state at some command of the profile")
    last = times >= (PERIODS - 1) * period
    e_dyn, e_qs = (dyn - rho)[last], (quasi - rho)[last]
    return Rendering(times, rho, dyn, quasi, float(np.sqrt(np.mean(e_dyn ** 2))), float(np.max(np.abs(e_dyn))),
                     float(np.sqrt(np.mean(e_qs ** 2))), float(np.max(np.abs(e_qs))), True)


def _steady_ratio(model: DynamicModel, gamma, tau2) -> float:
    """The quasi-static ratio ω2/ω1 at command γ with shaft 2's torque τ2: the dynamic model's steady state (the
    steady model's point)."""
    u = command(model, gamma, tau2, load_is_tau_2=True)
    x = steady_state(model, u)
    return np.nan if x is None else float(model.outputs(0, x, u, model.param_values)[1])


def _failed(times, rho, reason) -> Rendering:
    nan = np.full_like(times, np.nan)
    return Rendering(times, rho, nan, nan, np.nan, np.nan, np.nan, np.nan, False, reason)
