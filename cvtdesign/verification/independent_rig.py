"""The independent simulator's rig: rig-like data from the simulator of Kim's existing CVT (independent_sim.py)
over Kim's protocol or in a measured order, with the rig's noise, and the self-check's matrix of cases on it.

Like the simulator, this module imports numpy and pandas only, nothing else of cvtdesign's.

`CASES` is the self-check matrix: dicts {id, effects (for `simulate`), truth, note, seed, base}. Every
case's data is Kim's base (both creeps at his ε) plus the withheld effect; `base` is the model the diagnosis
should be run with (Kim's two creeps, or one of them for the cases that withhold the other). The right
answer (`truth`):

* a withheld in-vocabulary effect: its name (for the two base creeps: the one missing from `base`);
* a withheld out-of-vocabulary effect: `unexplained` (never a name: no effect of the vocabulary has its
  form; each leaves a residual above the noise after the base scales are refitted, see the table at CASES);
* the nulls (the data are exactly the base): `none`.

Units: SI inside (m, N, N·m, rad, rad/s); the data columns use degrees for angles.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from cvtdesign.verification.independent_sim import BASE, STATUS, solve

KIM_GAMMAS_DEG = np.arange(-80, 81, 10)
KIM_LOADS = np.round(np.arange(-1, 1.0001, 0.2), 10)
NOISE = (0.01, 0.005, 0.05)      # σ: speeds [rad/s], torques [N m], axis angle [deg]
COLUMNS = ("gamma_cmd_deg", "omega_1", "omega_2", "tau_1", "tau_2", "gamma_axis_deg")


def simulate(effects: dict[str, float], gammas_deg=range(-80, 81, 10), loads=KIM_LOADS, omega_1=10.0,
             replicates=1, noise=NOISE, seed=0, axis=True) -> tuple[pd.DataFrame, dict]:
    """Rig-like data in the measured-data format (columns gamma_cmd_deg, omega_1, omega_2, tau_1, tau_2 and,
    with `axis`, gamma_axis_deg) over the grid γ_cmd [deg] × τ⊥ [N m] (Kim's protocol by default: 187
    points), ω1 held at omega_1 [rad/s]. Each replicate adds independent Gaussian noise with σ = noise =
    (speed [rad/s], torque [N m], axis angle [deg]) to both speeds, both torques and the axis angle.
    Returns (rows, left_out): left_out counts the operating points (not rows) that the rig cannot measure,
    by reason: not_converged, lost_contact, gross_slip (only reasons that occurred)."""
    G, T = np.meshgrid(np.radians(np.asarray(list(gammas_deg), float)), np.asarray(loads, float), indexing="ij")
    res = solve(G, T, effects, omega_1)
    rng = np.random.default_rng(seed)
    blocks = [_measured(res, res["ok"], rng, noise, axis) for _ in range(int(replicates))]
    return pd.concat(blocks, ignore_index=True), _left_out(res["status"])


def simulate_sequence(effects: dict[str, float], gammas_deg, loads, omega_1=10.0, noise=NOISE, seed=0,
                      axis=True, backlash=0.0, drift=None, seconds_per_row=0.0) -> tuple[pd.DataFrame, dict]:
    """Rig-like data at the operating points (γ_cmd [deg], τ⊥ [N m]) in the order given, the order the rig
    measured them, with two things a steady-state model does not have:

    * `backlash` [rad]: lost motion in the steering linkage. The forks stop short of the commanded angle by
      half of it in the sense they were moving: φ − b/2 when γ_cmd was approached from below (rising since
      the last different γ), φ + b/2 from above (the first point counts as approached from below).
    * `drift` {effect: relative change}: the effect's strength grows linearly over the test, by that fraction
      from the first row to the last (e.g. {'drive_longitudinal_creep': 0.4}: the urethane warming up); the
      rows are solved in 32 groups of consecutive rows, each at its mean strength.

    With `seconds_per_row` > 0 a `time_s` column gives each row's time. Returns (rows, left_out) as
    `simulate`."""
    g = np.radians(np.asarray(gammas_deg, float))
    t = np.asarray(loads, float)
    n = g.size
    direction = _approach(g)
    offset = effects.get("steering_offset", 0.0)
    res = {}
    groups = np.array_split(np.arange(n), 32 if drift else 1)
    for idx in groups:
        for sense in (1, -1):
            sel = idx[direction[idx] == sense]
            if not sel.size:
                continue
            eff = dict(effects)
            for e, rel in (drift or {}).items():
                eff[e] = effects.get(e, 0.0) * (1 + rel * float(np.mean(sel)) / max(n - 1, 1))
            if backlash:
                eff["steering_offset"] = offset - sense * backlash / 2
            part = solve(g[sel], t[sel], eff, omega_1)
            for k, v in part.items():
                res.setdefault(k, np.zeros(np.shape(v)[:-1] + (n,), np.asarray(v).dtype))[..., sel] = v
    rows = _measured(res, res["ok"], np.random.default_rng(seed), noise, axis)
    if seconds_per_row > 0:
        rows["time_s"] = np.flatnonzero(res["ok"]) * seconds_per_row
    return rows, _left_out(res["status"])


def _approach(g: np.ndarray) -> np.ndarray:
    """+1 where a commanded γ was approached from below (rising since the last different γ), −1 from above."""
    out = np.ones(g.size, int)
    for k in range(1, g.size):
        d = g[k] - g[k - 1]
        out[k] = out[k - 1] if d == 0 else (1 if d > 0 else -1)
    return out


def _measured(res: dict, ok: np.ndarray, rng, noise, axis: bool) -> pd.DataFrame:
    """One measurement of each `ok` point of a solve: its speeds, torques and (with `axis`) axis angle plus
    Gaussian noise σ = noise (speed [rad/s], torque [N m], axis angle [deg])."""
    s_w, s_t, s_ax = noise
    n = int(ok.sum())
    b = {"gamma_cmd_deg": np.degrees(res["gamma_cmd"][ok]),
         "omega_1": res["omega_1"][ok] + s_w * rng.standard_normal(n),
         "omega_2": res["omega_2"][ok] + s_w * rng.standard_normal(n),
         "tau_1": res["tau_1"][ok] + s_t * rng.standard_normal(n),
         "tau_2": res["tau_2"][ok] + s_t * rng.standard_normal(n)}
    if axis:
        b["gamma_axis_deg"] = np.degrees(res["gamma_axis"][ok]) + s_ax * rng.standard_normal(n)
    return pd.DataFrame(b)


def _left_out(status: np.ndarray) -> dict:
    return {STATUS[k]: int(np.sum(status == k)) for k in (1, 2, 3) if np.any(status == k)}


def signal_to_noise(effects: dict, reference: dict, noise=NOISE, omega_1=10.0) -> dict:
    """How visible the difference between two effect sets is over Kim's protocol (noise-free truths at the
    points both can run), per channel in units of its measurement σ: α (σ_α = σ_ω/|(ω1, ω2)|), τ∥
    (σ_τ) and the axis angle. Returns {channel: (RMS z, χ = √Σz²)} and 'points'."""
    G, T = np.meshgrid(np.radians(KIM_GAMMAS_DEG.astype(float)), KIM_LOADS, indexing="ij")
    a, b = solve(G, T, effects, omega_1), solve(G, T, reference, omega_1)
    ok = a["ok"] & b["ok"]
    g = a["gamma_cmd"][ok]
    s_alpha = noise[0] / np.hypot(a["omega_1"][ok], a["omega_2"][ok])
    tp = lambda r: r["tau_1"][ok] * np.cos(g) + r["tau_2"][ok] * np.sin(g)  # noqa: E731
    z = {"alpha": (a["alpha"][ok] - b["alpha"][ok]) / s_alpha,
         "tau_par": (tp(a) - tp(b)) / noise[1],
         "axis": np.degrees(a["gamma_axis"][ok] - b["gamma_axis"][ok]) / noise[2]}
    out = {k: (float(np.sqrt(np.mean(v ** 2))), float(np.sqrt(np.sum(v ** 2)))) for k, v in z.items()}
    out["points"] = int(ok.sum())
    return out


# ------------------------------------------------------------------------------------ the self-check matrix

def _case(cid, extra, truth, note, seed, base=("drive_longitudinal_creep", "steering_lateral_creep")):
    effects = dict(BASE)
    effects.update(extra)
    return {"id": cid, "effects": effects, "truth": truth, "note": note, "seed": seed, "base": list(base)}


# Visibility over Kim's protocol (187 points, noise σ = 0.01 rad/s, 0.005 N m, 0.05°): per-point RMS of
# the change in α, τ∥ and the axis angle in σ (α's σ = σ_ω/|(ω1, ω2)|), first against the base's truth,
# then after a least-squares refit of the base's scales (what a base-only fit cannot absorb); χ = √Σz².
#   case                              raw α / τ∥ / axis     χ  | refit: α / τ∥ / axis    χ
#   drive_longitudinal_creep-kim      54.6 /  0   /  0     746 |       35.2 / 0   / 13.7  516
#   drive_longitudinal_creep-half     27.1 /  0   /  0     370 |       17.4 / 0   /  7.0  256
#   steering_lateral_creep-kim       160   /  0   / 62.5  2354 |       81   / 0   / 62.5 1400
#   steering_lateral_creep-half       69.3 /  0   / 31.3  1040 |       36.0 / 0   / 31.3  652
#   drive_spin_creep-clear            33.1 /  0   /  0     453 |        9.1 / 0   /  9.3  178
#   drive_spin_creep-moderate          7.5 /  0   /  0     103 |        2.3 / 0   /  2.1   43
#   normal_force_variation-clear      18.0 /  0   /  4.0   253 |       10.4 / 0   /  3.5  149
#   normal_force_variation-moderate    7.1 /  0   /  1.0    99 |        4.1 / 0   /  1.1   58
#   rolling_resistance-clear           6.4 / 12.1 /  1.5   188 |        5.7 / 12.1 / 2.1  184
#   rolling_resistance-moderate        1.9 /  3.6 /  0.5    56 |        1.7 / 3.6 /  0.6   55
#   steering_offset-clear             25.8 /  1.2 / 10.9   383 |       25.4 / 1.2 / 11.1  380
#   steering_offset-moderate           7.9 /  0.4 /  3.3   117 |        7.6 / 0.4 /  3.4  114
#   drive_radius_mismatch-clear        6.9 /  0.5 /  0.4    95 |        6.7 / 0.5 /  0.3   92
#   drive_radius_mismatch-moderate     2.1 /  0.1 /  0.1    29 |        2.0 / 0.1 /  0.1   28
#   traction_saturation-clear         33.5 /  0   /  8.1   471 |       12.6 / 0   /  4.1  181
#   traction_saturation-moderate       6.5 /  0   /  1.8    93 |        2.4 / 0   /  0.8   35
#   fork_compliance-clear            115   /  4.7 / 32.0  1638 |        3.3 / 4.7 /  1.2   80
#   fork_compliance-moderate          57.1 /  2.8 / 19.2   825 |        1.5 / 2.8 /  0.6   45
#   speed_dependent_creep-clear       12.1 /  0   /  1.4   167 |        4.6 / 0   /  3.8   81
#   speed_dependent_creep-moderate     5.5 /  0   /  0.7    76 |        2.1 / 0   /  1.7   37
#   viscous_loss-clear                 4.8 /  7.8 /  0.6   125 |        4.2 / 7.8 /  1.3  122
#   viscous_loss-moderate              1.4 /  2.3 /  0.2    37 |        1.3 / 2.3 /  0.4   37
#   creep_reference-roller             2.2 /  0   /  0      30 |        2.1 / 0   /  0.4   29
# (pure creep is a flow loss: it moves α, not τ∥; τ∥ moves with resisting torques and with geometry that
# turns the forces, such as the fork yaw or the steering offset)
CASES = [
    # the base effects themselves, withheld from a diagnosis base that lacks them (Kim's historical replay)
    _case("drive_longitudinal_creep-kim", {}, "drive_longitudinal_creep",
          "Kim's machine; the diagnosis base has only steering_lateral_creep", 11, ["steering_lateral_creep"]),
    _case("drive_longitudinal_creep-half", {"drive_longitudinal_creep": 0.5}, "drive_longitudinal_creep",
          "ε_D at half Kim's value; base has only steering_lateral_creep", 12, ["steering_lateral_creep"]),
    _case("steering_lateral_creep-kim", {}, "steering_lateral_creep",
          "Kim's machine; the diagnosis base has only drive_longitudinal_creep", 13, ["drive_longitudinal_creep"]),
    _case("steering_lateral_creep-half", {"steering_lateral_creep": 0.5}, "steering_lateral_creep",
          "ε_S at half Kim's value; base has only drive_longitudinal_creep", 14, ["drive_longitudinal_creep"]),
    # in the vocabulary, withheld from Kim's base
    _case("drive_spin_creep-clear", {"drive_spin_creep": 0.004}, "drive_spin_creep",
          "line-contact half-width 4 mm (4× the nominal; Brokowski's fitted k were 4-9× nominal)", 21),
    _case("drive_spin_creep-moderate", {"drive_spin_creep": 0.001}, "drive_spin_creep",
          "half-width 1 mm (Brokowski's nominal k = 0.00056 /(in lbf) ≈ (a/R)/(r μ N) with a ≈ 1 mm)", 22),
    _case("normal_force_variation-clear", {"normal_force_variation": 3.0}, "normal_force_variation",
          "ε ∝ N^-3 (amplified: at the Hertz exponent 2/3 the signature is ≈ 1σ per point)", 23),
    _case("normal_force_variation-moderate", {"normal_force_variation": 2.0}, "normal_force_variation",
          "ε ∝ N^-2", 24),
    _case("rolling_resistance-clear", {"rolling_resistance": 0.005}, "rolling_resistance",
          "C_rr = 0.005 (0.02 N m on a drive roller at 100 N)", 25),
    _case("rolling_resistance-moderate", {"rolling_resistance": 0.0015}, "rolling_resistance", "C_rr = 0.0015", 26),
    _case("steering_offset-clear", {"steering_offset": float(np.radians(0.5))}, "steering_offset", "φ + 0.5°", 27),
    _case("steering_offset-moderate", {"steering_offset": float(np.radians(-0.15))}, "steering_offset",
          "φ − 0.15°", 28),
    _case("drive_radius_mismatch-clear", {"drive_radius_mismatch": 0.01}, "drive_radius_mismatch",
          "shaft 2 rolls on 1.01 r", 29),
    _case("drive_radius_mismatch-moderate", {"drive_radius_mismatch": -0.003}, "drive_radius_mismatch",
          "shaft 2 rolls on 0.997 r", 30),
    _case("traction_saturation-clear", {"traction_saturation": 0.5}, "traction_saturation",
          "μ = 0.4 with the atan saturation law", 31),
    _case("traction_saturation-moderate", {"traction_saturation": 1.0}, "traction_saturation",
          "μ = 0.8 (Kim's) with the atan saturation law", 32),
    # outside the vocabulary
    _case("fork_compliance-clear", {"fork_compliance": 0.0025}, "unexplained",
          "c_f = 2.5 mrad/N; in α alone it looks like ε_S × 1.5, the torques tell it apart", 41),
    _case("fork_compliance-moderate", {"fork_compliance": 0.0015}, "unexplained",
          "c_f = 1.5 mrad/N; in α alone it looks like ε_S × 1.3", 42),
    _case("speed_dependent_creep-clear", {"speed_dependent_creep": 0.02}, "unexplained",
          "creep compliance × (1 + 0.02 s/m·|v|)", 43),
    _case("speed_dependent_creep-moderate", {"speed_dependent_creep": 0.01}, "unexplained",
          "creep compliance × (1 + 0.01 s/m·|v|)", 44),
    _case("viscous_loss-clear", {"viscous_loss": 5e-4}, "unexplained",
          "resisting torque 5e-4 N m s/rad × roller speed", 45),
    _case("viscous_loss-moderate", {"viscous_loss": 1.5e-4}, "unexplained",
          "resisting torque 1.5e-4 N m s/rad × roller speed", 46),
    _case("creep_reference-roller", {"creep_reference": 1.0}, "unexplained",
          "creepage against the rollers' surface speed instead of the sphere's (a second-order difference, "
          "≈ 2σ per point; the only strength there is: λ = 0.5 is ≈ 1σ)", 47),
    # nulls: exactly the base
    _case("null-1", {}, "none", "Kim's base creep only", 51),
    _case("null-2", {}, "none", "Kim's base creep only, another seed", 52),
]
