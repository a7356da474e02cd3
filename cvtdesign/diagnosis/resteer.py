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
from scipy.optimize import brentq

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
    """Speed ratio ω2/ω1 of `model` at commanded γ [rad] under lateral load τ⊥ [N m]."""
    g = np.atleast_1d(np.asarray(gammas, float))
    res = model.evaluate(g, np.full_like(g, load), theta=theta)
    return res["omega_2"] / res["omega_1"]


def ideal_command(layout, rho) -> float:
    """γ [rad] of the layout's ideal law (ω2/ω1 = (r1/r2) tan γ for Kim's layout) for the speed ratio ρ."""
    return float(shaft_frame(layout).command_for_ratio(rho))


def model_command(model, rho, load, theta=None) -> float:
    """γ_cmd [rad] at which the model's ω2/ω1 equals `rho` under τ⊥ = load; NaN outside the variant's range."""
    L = model.layout
    lo_lim, hi_lim = float(L.gamma_grid.min()), float(L.gamma_grid.max())
    g0 = ideal_command(L, rho)
    grid = np.clip(np.linspace(g0 - SEARCH, g0 + SEARCH, 21), lo_lim, hi_lim)
    f = ratio(model, grid, load, theta) - rho
    k = np.flatnonzero(np.isfinite(f[:-1]) & np.isfinite(f[1:]) & (np.sign(f[:-1]) != np.sign(f[1:])))
    if k.size == 0:
        return float("nan")
    k = k[np.argmin(np.abs(grid[k] - g0))]
    return float(brentq(lambda g: ratio(model, g, load, theta)[0] - rho, grid[k], grid[k + 1], xtol=1e-10))


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


def commands(layout, effects, load, ratios=RATIOS, data=None) -> dict:
    """Steering commands γ_cmd [rad] per method for each requested ratio, and the fitted parameters."""
    if not math.isfinite(load):     # (the command line also holds an explicit --load to the envelope: check_load)
        raise InputError(f"load: expected a finite lateral load τ⊥ [N m], got {load}")
    if not all(math.isfinite(q) and q > 0 for q in ratios):
        raise InputError(f"ratios: expected finite positive speed ratios ω2/ω1, got {list(ratios)}")
    fitted = fit_model(layout, data, effects) if data is not None else None
    model = fitted[0].model if fitted else compile_model(layout, effects)    # one compiled model for both
    out = {"ratios": list(ratios), "load": load, "methods": {}, "fit": None}
    out["methods"]["ideal"] = [ideal_command(layout, q) for q in ratios]
    out["methods"]["nominal"] = [model_command(model, q, load) for q in ratios]
    if fitted:
        f = fitted[1]
        out["fit"] = f.params()
        out["methods"]["fitted"] = [model_command(model, q, load, f.theta) for q in ratios]
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
