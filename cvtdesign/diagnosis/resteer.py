"""Resteering (Brokowski sec. 5): the steering command that gives a requested speed ratio under a known load.

Methods compared as in Brokowski Fig. 17:
 * ideal: the kinematic law ω2/ω1 = (r1/r2) tan γ inverted;
 * nominal: the model with the variant's effect parameters, inverted (γ_cmd such that the predicted ω2/ω1 is
   the requested ratio at the load τ⊥);
 * fitted: the same model with its parameters fitted to measured data (diagnose.fit_model);
 * lookup: inverted interpolation of the measured speed ratio against γ_cmd at the data's load level nearest
   the requested load (Brokowski's "inverted table lookup").
The achieved ratio of each command is then measured on the CVT (here: the virtual rig's true model), and
scored by Brokowski eq 23: error = (requested − achieved)/requested [%].
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from cvtdesign.core.kinematics import shaft_frame
from cvtdesign.core.model import compile_model
from cvtdesign.diagnosis.diagnose import fit_model
from cvtdesign.errors import InputError, shorten

RATIOS = (0.4, 0.5, 0.8, 1.0, 1.25, 2.0, 2.5)     # Brokowski sec. 5.2 requested speed ratios
SEARCH = np.radians(25.0)                         # [rad] search half-width about the ideal command


def check_load(layout, load: float, where: str = "load") -> float:
    """The lateral load τ⊥ [N m] of a resteering request: finite and within the variant's envelope load range
    (the model is validated there; far outside it every contact slips and no command exists)."""
    lo, hi = float(np.min(layout.load_grid)), float(np.max(layout.load_grid))
    if not (math.isfinite(load) and lo - 1e-12 <= load <= hi + 1e-12):
        raise InputError(f"{where}: τ⊥ = {load:g} N·m is outside the variant's envelope load range {lo:g}..{hi:g} N·m "
                         f"(envelope.load of {layout.file}); expected a load in that range")
    return float(load)


def parse_ratios(text: str, where: str = "ratios") -> list[float]:
    """'0.4,1,2.5' → requested speed ratios ω2/ω1: finite and positive."""
    try:
        ratios = [float(x) for x in text.split(",")]
    except ValueError:
        raise InputError(f"{where}: expected comma-separated numbers, got '{shorten(text)}'") from None
    if not ratios or not all(math.isfinite(q) and q > 0 for q in ratios):
        raise InputError(f"{where}: expected finite positive speed ratios ω2/ω1, got '{shorten(text)}'")
    return ratios


def default_load(layout, data) -> float:
    """τ⊥ [N m] of a resteering request that names none: the data's highest load level inside the variant's
    envelope load range (the model is validated there), else the envelope's highest load. A level is a mean
    of measured loads, so it may lie past the range by noise: within 2.5 % of the range counts as inside
    (Kim's top level measured 1.0019 N·m, and resteering dropped to the 0.8 N·m level)."""
    lo, hi = float(np.min(layout.load_grid)), float(np.max(layout.load_grid))
    if data is None:
        return hi
    slack = 0.025 * (hi - lo)
    inside = data.load_levels[(data.load_levels >= lo - slack) & (data.load_levels <= hi + slack)]
    if inside.size == 0:
        raise InputError(f"{data.file}: every load level of the data lies outside the envelope load range "
                         f"{lo:g}..{hi:g} N·m of {layout.file}; expected --load inside that range")
    return float(inside.max())


def check_ratios(layout, ratios, where: str = "ratios") -> list[float]:
    """Requested speed ratios the variant's ideal law reaches inside its envelope's γ range: beyond it no
    command exists (100 would need γ = 89.4° on Kim's CVT, whose envelope ends at 80°)."""
    frame = shaft_frame(layout)
    lo, hi = sorted(float(frame.ideal_ratio(g)) for g in (layout.gamma_grid.min(), layout.gamma_grid.max()))
    for q in ratios:
        g = math.degrees(frame.command_for_ratio(q))
        if not lo <= q <= hi:
            raise InputError(f"{where}: ω2/ω1 = {q:g} needs γ = {g:.1f} deg by the ideal law, outside the envelope "
                             f"γ range {np.degrees(layout.gamma_grid.min()):g}..{np.degrees(layout.gamma_grid.max()):g}"
                             f" deg of {layout.file}; expected "
                             + (f"ratios up to {hi:.3g}" if lo <= 0 else f"ratios from {lo:.3g} to {hi:.3g}"))
    return list(ratios)


def ratio(model, gammas, load, theta=None) -> np.ndarray:
    """Speed ratio ω2/ω1 of `model` at commanded γ [rad] under lateral load τ⊥ [N m] (broadcast; flattened)."""
    g, tau = np.broadcast_arrays(np.atleast_1d(np.asarray(gammas, float)), np.asarray(load, float))
    res = model.evaluate(g.ravel(), tau.ravel(), theta=theta)
    return res["omega_2"] / res["omega_1"]


def ideal_command(layout, rho) -> float:
    """γ [rad] of the layout's ideal law (ω2/ω1 = (r1/r2) tan γ for Kim's layout) for the speed ratio ρ."""
    return float(shaft_frame(layout).command_for_ratio(rho))


def model_command(model, rho, load, theta=None) -> float:
    """γ_cmd [rad] at which the model's ω2/ω1 equals `rho` under τ⊥ = load; NaN outside the variant's range."""
    return float(model_commands(model, rho, load, theta)[0][0])


SCAN_POINTS = 21       # points of the scan about the ideal command (model_commands)
FTOL = 1e-12           # relative ratio error |ω2/ω1 − ρ|/(1 + |ρ|) at which a command is found
XTOL = 1e-12           # [rad] bracket width at which a command is found whatever its ratio error
MAX_STEPS = 60         # most steps of the bracket's refinement
REASONS = ("ok", "unreachable", "no_solution")   # model_commands: why a command is (not) given


def model_commands(model, ratios, loads, theta=None) -> tuple[np.ndarray, np.ndarray]:
    """The model inverted for many requests at once: γ_cmd [rad] at which the model's ω2/ω1 equals each
    requested ratio ρ under its lateral load τ⊥ [N m] (broadcast arrays; flattened on return), with the reason
    (a REASONS name) per request. The model's ratio is scanned at SCAN_POINTS commands within ±SEARCH of
    the ideal command (clipped to the envelope's γ range); the scanned point or sign change nearest the ideal
    command is then refined by regula falsi (the Illinois variant, which keeps a bracket) until the ratio is
    within FTOL, every request in one `evaluate` call per step. No command is given (NaN) where the scan
    finds no crossing and every scanned point holds ('unreachable': the ratio needs a γ past the envelope
    under that load), or where a point of the scan or of the refinement has no physical solution and the
    crossing is not found among the others ('no_solution': gross slip, lost contact, no convergence)."""
    rho, load = (a.ravel() for a in np.broadcast_arrays(np.asarray(ratios, float), np.asarray(loads, float)))
    L = model.layout
    g0 = np.asarray(shaft_frame(L).command_for_ratio(rho), float)
    grid = np.clip(g0[:, None] + np.linspace(-SEARCH, SEARCH, SCAN_POINTS), L.gamma_grid.min(), L.gamma_grid.max())
    f = ratio(model, grid, load[:, None], theta).reshape(grid.shape) - rho[:, None]
    tol = FTOL * (1 + np.abs(rho))
    a, b, fa, fb, found = _bracket(grid, f, g0, tol)
    why = np.where(found, 0, np.where(np.isfinite(f).all(axis=1), 1, 2))
    x = np.where(np.abs(fa) <= tol[:], a, b)
    active = found & (np.abs(fa) > tol) & (np.abs(fb) > tol)
    side = np.zeros(rho.size)
    for _ in range(MAX_STEPS):
        if not active.any():
            break
        c = np.where(active, (a * fb - b * fa) / np.where(active, fb - fa, 1.0), g0)
        fc = ratio(model, c, load, theta) - rho
        lost = active & ~np.isfinite(fc)
        why[lost], active = 2, active & ~lost
        x = np.where(active, c, x)
        with_b = active & (np.sign(fc) == np.sign(fb))           # c replaces b; halve fa if b moved twice
        a_side = active & ~with_b
        fa = np.where(with_b & (side == -1), fa / 2, fa)
        fb = np.where(a_side & (side == 1), fb / 2, fb)
        b, fb = np.where(with_b, c, b), np.where(with_b, fc, fb)
        a, fa = np.where(a_side, c, a), np.where(a_side, fc, fa)
        side = np.where(with_b, -1, np.where(a_side, 1, side))
        active &= (np.abs(fc) > tol) & (np.abs(b - a) > XTOL)
    why[active] = 2                                                  # not refined within MAX_STEPS
    return np.where(why == 0, x, np.nan), np.array(REASONS, dtype=object)[why]


def _bracket(grid, f, g0, tol):
    """Per request, the candidate nearest the ideal command g0 among the scanned points within tol of the
    ratio (a bracket of zero width) and the sign changes between neighbours: (a, b, f(a), f(b), found)."""
    n = grid.shape[1]
    hit = np.isfinite(f) & (np.abs(f) <= tol[:, None])
    change = np.isfinite(f[:, :-1]) & np.isfinite(f[:, 1:]) & (np.sign(f[:, :-1]) != np.sign(f[:, 1:]))
    lo = np.concatenate([np.arange(n), np.arange(n - 1)])
    hi = np.concatenate([np.arange(n), np.arange(1, n)])
    valid = np.concatenate([hit, change], axis=1)
    k = np.argmin(np.where(valid, np.abs(grid[:, lo] - g0[:, None]), np.inf), axis=1)
    rows = np.arange(grid.shape[0])
    return (grid[rows, lo[k]], grid[rows, hi[k]], f[rows, lo[k]], f[rows, hi[k]], valid.any(axis=1))


def lookup_command(data, rho, load) -> tuple[float, float]:
    """Inverted lookup in the data (Brokowski sec. 5.2): at the load level nearest `load`, the measured
    ω2/ω1 (mean over replicates) against γ_cmd, interpolated linearly between the bracketing commands.
    Returns (γ_cmd [rad], the load level used [N m])."""
    r = data.rows
    j = int(np.argmin(np.abs(data.load_levels - load)))
    sel = r[r["load_bin"] == j]
    pts = sel.assign(ratio=sel["omega_2"] / sel["omega_1"]).groupby("gamma_cmd_deg")["ratio"].mean()
    g, q = np.radians(pts.index.to_numpy()), pts.to_numpy()
    k = np.flatnonzero((q[:-1] - rho) * (q[1:] - rho) <= 0)
    if k.size == 0:
        return float("nan"), float(data.load_levels[j])
    k = k[0]
    t = (rho - q[k]) / (q[k + 1] - q[k]) if q[k + 1] != q[k] else 0.0
    return float(g[k] + t * (g[k + 1] - g[k])), float(data.load_levels[j])


def model_and_fit(layout, effects, data=None):
    """(compiled model, fit): the model with `effects`, and with measured data its fit (diagnose.fit_model;
    fit.theta its fitted parameters, one compiled model for the nominal and the fitted commands), else None."""
    if data is None:
        return compile_model(layout, effects), None
    return compile_model(layout, effects), fit_model(layout, data, effects)[1]


def commands(layout, effects, load, ratios=RATIOS, data=None) -> dict:
    """Steering commands γ_cmd [rad] per method for each requested ratio, and the fitted parameters."""
    if not math.isfinite(load):     # (the command line also holds an explicit --load to the envelope: check_load)
        raise InputError(f"load: expected a finite lateral load τ⊥ [N m], got {load}")
    if not all(math.isfinite(q) and q > 0 for q in ratios):
        raise InputError(f"ratios: expected finite positive speed ratios ω2/ω1, got {list(ratios)}")
    model, fit = model_and_fit(layout, effects, data)
    out = {"ratios": list(ratios), "load": load, "methods": {}, "fit": None}
    out["methods"]["ideal"] = [ideal_command(layout, q) for q in ratios]
    out["methods"]["nominal"] = [model_command(model, q, load) for q in ratios]
    if fit:
        out["fit"] = fit.params()
        out["methods"]["fitted"] = [model_command(model, q, load, fit.theta) for q in ratios]
        looked = [lookup_command(data, q, load) for q in ratios]
        out["methods"]["lookup"] = [g for g, _ in looked]
        out["lookup_load"] = looked[0][1]
    return out


def achieved(truth_model, cmds: dict) -> dict:
    """Run every command on the CVT (the rig's true model) and score it by Brokowski eq 23 [%]."""
    table = {}
    for m, gs in cmds["methods"].items():
        gs = np.asarray(gs, float)
        q = np.full(gs.size, np.nan)
        ok = np.isfinite(gs)
        if ok.any():
            q[ok] = ratio(truth_model, gs[ok], cmds["load"])
        req = np.asarray(cmds["ratios"], float)
        err = 100 * (req - q) / req
        scored = np.isfinite(err)       # NaN where no command, or where the CVT has no physical solution
        table[m] = {"gamma_cmd_deg": np.degrees(gs).tolist(), "achieved": q.tolist(), "error_pct": err.tolist(),
                    "mean_abs_error_pct": float(np.mean(np.abs(err[scored]))) if scored.any() else float("nan")}
    return table


# ---------------------------------------------------------------------------------------- the controller table

AXIS_MAX = 1001        # most values of a table axis
TABLE_COLUMNS = ("ratio", "tau_perp_Nm", "gamma_cmd_deg", "gamma_ideal_deg", "ideal_ratio_error",
                 "residual_ratio_error", "status")     # the controller table's CSV columns (docs/diagnosis.md)


def parse_axis(text: str, where: str, convert) -> list[float]:
    """A table axis: 'a,b,c' (increasing) or 'START:STOP:COUNT' (COUNT evenly spaced values, START < STOP,
    2 ≤ COUNT ≤ AXIS_MAX); each value through convert(text, where) → float (SI)."""
    parts = text.split(":")
    if len(parts) == 3:
        try:
            count = int(parts[2])
        except ValueError:
            raise InputError(f"{where}: COUNT of START:STOP:COUNT must be a whole number, got '{shorten(parts[2])}'") \
                from None
        start, stop = convert(parts[0], where), convert(parts[1], where)
        if not 2 <= count <= AXIS_MAX or not start < stop:
            raise InputError(f"{where}: expected START < STOP and 2 ≤ COUNT ≤ {AXIS_MAX} in START:STOP:COUNT, got "
                             f"'{shorten(text)}'")
        return np.linspace(start, stop, count).tolist()
    if len(parts) != 1:
        raise InputError(f"{where}: expected comma-separated values or START:STOP:COUNT, got '{shorten(text)}'")
    values = [convert(v, where) for v in text.split(",")]
    if not 2 <= len(values) <= AXIS_MAX or np.any(np.diff(values) <= 0):
        raise InputError(f"{where}: expected 2 to {AXIS_MAX} increasing values, got '{shorten(text)}'")
    return values


def ratio_value(text: str, where: str) -> float:
    """One finite speed ratio ω2/ω1 of a table axis (any sign: γ < 0 gives negative ratios)."""
    try:
        q = float(text)
    except ValueError:
        raise InputError(f"{where}: expected numbers (speed ratios ω2/ω1), got '{shorten(text)}'") from None
    if not math.isfinite(q):
        raise InputError(f"{where}: expected finite speed ratios ω2/ω1, got '{shorten(text)}'")
    return q


def default_axes(layout) -> tuple[list[float], list[float]]:
    """The table's axes from the variant's envelope: the ideal law's ratio at each γ of its grid (increasing)
    and its τ⊥ grid [N m]."""
    ratios = np.sort(np.asarray(shaft_frame(layout).ideal_ratio(layout.gamma_grid), float))
    return ratios.tolist(), np.asarray(layout.load_grid, float).tolist()


def command_table(model, ratios, loads, theta=None) -> dict:
    """γ_cmd over the (ratio, τ⊥) grid (model_commands), as arrays of shape (ratios, loads): 'ratio',
    'tau_perp' [N m], 'gamma_cmd' and 'gamma_ideal' [rad], 'ideal_ratio_error' (the model's ω2/ω1 at the
    ideal command minus the requested ratio: what the table corrects), 'residual_ratio_error' (the same at
    γ_cmd: what it leaves), 'status' (REASONS); NaN where there is no number."""
    R, T = np.meshgrid(np.asarray(ratios, float), np.asarray(loads, float), indexing="ij")
    g, why = model_commands(model, R, T, theta)
    g_ideal = np.asarray(shaft_frame(model.layout).command_for_ratio(R.ravel()), float)
    at_ideal = ratio(model, g_ideal, T.ravel(), theta)
    at_cmd = np.full(g.size, np.nan)
    if np.isfinite(g).any():
        at_cmd[np.isfinite(g)] = ratio(model, g[np.isfinite(g)], T.ravel()[np.isfinite(g)], theta)
    return {"ratio": R, "tau_perp": T, "gamma_cmd": g.reshape(R.shape), "gamma_ideal": g_ideal.reshape(R.shape),
            "ideal_ratio_error": (at_ideal - R.ravel()).reshape(R.shape),
            "residual_ratio_error": (at_cmd - R.ravel()).reshape(R.shape), "status": why.reshape(R.shape)}


def interpolation_error(model, table: dict, theta=None) -> dict:
    """What a controller interpolating the table bilinearly leaves: at the centre of every grid cell whose four
    corners have a command, the model's ω2/ω1 at the mean of their γ_cmd minus the requested ratio there
    (the mean of the corners' ratios). Returns {'max_abs', 'ratio', 'tau_perp'} of the worst cell (None where
    no cell has four commands) and 'cells', how many were checked."""
    centre = {k: 0.25 * (a[:-1, :-1] + a[1:, :-1] + a[:-1, 1:] + a[1:, 1:])
              for k, a in ((k, table[k]) for k in ("gamma_cmd", "ratio", "tau_perp"))}
    known = np.isfinite(centre["gamma_cmd"])      # NaN where a corner has no command
    if not known.any():
        return {"max_abs": None, "ratio": None, "tau_perp": None, "cells": 0}
    err = np.abs(ratio(model, centre["gamma_cmd"][known], centre["tau_perp"][known], theta) - centre["ratio"][known])
    k = int(np.nanargmax(err)) if np.isfinite(err).any() else 0
    return {"max_abs": float(np.nanmax(err)) if np.isfinite(err).any() else None,
            "ratio": float(centre["ratio"][known][k]), "tau_perp": float(centre["tau_perp"][known][k]),
            "cells": int(known.sum())}


def table_csv(table: dict) -> str:
    """The controller table as CSV text (TABLE_COLUMNS; docs/diagnosis.md): one row per grid node, the ratios
    in the outer order and the loads in the inner, angles in degrees; an empty field where there is no
    number (no command: status says why)."""
    frame = pd.DataFrame({
        "ratio": table["ratio"].ravel(), "tau_perp_Nm": table["tau_perp"].ravel(),
        "gamma_cmd_deg": np.degrees(table["gamma_cmd"].ravel()), "gamma_ideal_deg": np.degrees(table["gamma_ideal"].ravel()),
        "ideal_ratio_error": table["ideal_ratio_error"].ravel(),
        "residual_ratio_error": table["residual_ratio_error"].ravel(), "status": table["status"].ravel()})
    return frame[list(TABLE_COLUMNS)].to_csv(index=False, float_format="%.10g", na_rep="")
