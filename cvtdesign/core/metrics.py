"""Operating envelopes and the figures of merit that `cvtdesign compare` prints.

Figures (all over the variant's envelope, Kim's protocol by default: γ −80°..80° step 10°, τ⊥ −1..1 N·m):
 * max_abs_alpha_deg, rms_alpha_deg: CVT slip angle α = atan2(ω2·r2/r1, ω1) − γ_cmd (Kim eq 15);
 * max_abs_alpha_steering_deg / _drive_deg: its steering part γ_axis − γ_cmd and the rest (Kim eqs 24, 31);
 * ratio_error_pct_at_max_load: largest |Brokowski eq 23 error| (requested − achieved)/requested of the
   speed ratio ω2/ω1 at the highest |τ⊥|, over the γ whose ideal |ratio| lies in Brokowski's resteering
   range 0.4..2.5 (near γ = 0 and ±90° the ratio itself goes to 0 or ∞ and a relative error means little);
 * min_efficiency: power out / power in, whichever shaft the power enters, over the points that deliver power
   (it leaves at one shaft) with |γ| ≥ 5° and |τ⊥| ≥ 25 % of the largest load (at γ = 0 no power leaves the
   CVT, at zero load none enters); `efficiency_points` counts them and `no_output_points` the points of that
   range that deliver none (power enters both shafts: the losses exceed what the load returns);
 * max_loss_no_output_W: the largest power lost [W] at an ok point that delivers no power (zero load, γ = 0,
   or power entering both shafts), where an efficiency means nothing: under a law with a spin moment spin costs
   power even without load;
 * max_traction_utilisation: max |F|/(μN) over all contacts; max_hertz_pressure_MPa: max Hertz peak pressure;
 * max_steering_torque_Nm: the steering motor's largest |torque| [N·m] while the contacts roll, through the
   linkage; max_standstill_steering_torque_Nm: the largest it needs to resteer with the sphere at rest, at
   the point's normal forces (core.steering); each `_at` names the fork with the largest share;
 * max_hertz_pressure_over_allowable: whether a contact's pressure exceeds its allowable (the smaller
   allowable_pressure of its two materials; None where neither gives one) at some point, with
   hertz_allowable_pressure_MPa the allowable of the contact nearest to or most over it and
   hertz_over_allowable_at the points over it per roller.

The ideal law, γ and α are the layout's own (kinematics.py). Every figure is taken over the points where the
physics holds; the points that lost contact, slip grossly, did not converge, reached a root with the sphere
turning backwards or have two roots are counted (`lost_contact`, `gross_slip`, `not_converged`, `reversed`,
`multiple_roots`, with the contacts behind the first two) and left out. A figure with no point to take
it over is None, never NaN.
"""
from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass

import numpy as np

from cvtdesign.core.contact.laws import IDEAL, contact_law
from cvtdesign.core.model import CompiledModel, compile_model, status_counts
from cvtdesign.core.status import Status
from cvtdesign.core.steering import NODES, SAMPLE_NODES, standstill_torques


ZERO_TORQUE = 1e-9     # [N m] a steering torque below this is round-off: no fork carries it


def ideal_model(layout) -> CompiledModel:
    """The ideal CVT of a layout: the same rollers and linkage with rigid rolling contacts (the ideal law,
    core.contact.laws.IDEAL, with no effects: no creep, no losses), whatever the layout's contact law. A law on
    a theory creeps with no effect on, so `effects=()` alone does not make it ideal."""
    return compile_model(dataclasses.replace(layout, contact_law=IDEAL), effects=())


def envelope(model: CompiledModel, theta=None, design=None) -> dict:
    """Evaluate the model on the variant's γ × τ⊥ grid (at effect parameters θ and design values, default the
    model's own and none); arrays have shape (n_gamma, n_load)."""
    L = model.layout
    G, T = np.meshgrid(L.gamma_grid, L.load_grid, indexing="ij")
    return _derived(model.evaluate(G, T, theta=theta, design=design), L)


def at_points(model: CompiledModel, gammas, loads, speeds=None) -> dict:
    """Evaluate the model at operating points of the caller's own (broadcastable arrays: commanded γ [rad],
    τ⊥ [N·m], motor speed ω1 [rad/s], default the variant's), with the figures `envelope` derives."""
    return _derived(model.evaluate(gammas, loads, speeds), model.layout)


def envelopes(model: CompiledModel, designs, thetas=None) -> list[dict]:
    """`envelope` at each row of `designs` (samples × design values) and of `thetas` (samples × effect
    parameters; default the model's own), all in one call of the model mapped over samples × points: the same
    numbers as one call a sample, without a call's fixed cost per sample. The standstill torques' quadrature
    takes core.steering.SAMPLE_NODES nodes (within 3e-4 of `envelope`'s at worst, far inside the samples'
    own spread; 3e-15 on the shipped variants)."""
    L, designs = model.layout, np.atleast_2d(np.asarray(designs, float))
    G, T = np.meshgrid(L.gamma_grid, L.load_grid, indexing="ij")
    shape = (len(designs),) + G.shape
    theta = None if thetas is None else np.repeat(np.atleast_2d(np.asarray(thetas, float)), G.size, axis=0)
    res = _derived(model.evaluate(np.broadcast_to(G, shape), np.broadcast_to(T, shape), theta=theta,
                                  design=np.repeat(designs, G.size, axis=0)), L, SAMPLE_NODES)
    return [{k: v[s] if v.ndim == len(shape) else v[:, s] for k, v in res.items()} for s in range(len(designs))]


def _derived(res: dict, L, nodes: int = NODES) -> dict:
    """An evaluation with the figures derived from it: efficiency and the standstill steering torques (their
    quadrature on `nodes`: core.steering.sliding_lever)."""
    res["efficiency"] = efficiency(res["tau_1"] * res["omega_1"], res["tau_2"] * res["omega_2"])
    res["T_fork_standstill"], res["steering_torque_standstill"] = standstill_torques(
        res, [r.fork_ratio for r in L.rollers], nodes)
    return res


def efficiency(p1, p2):
    """Power out / power in [-], whichever shaft the power enters (p_i = τ_i ω_i [W]); NaN without power in,
    0 when power enters both shafts (no power out: e.g. at γ = 0 with rolling resistance)."""
    p_in = np.maximum(p1, p2)
    p_out = np.maximum(-np.minimum(p1, p2), 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(p_in > 1e-12, p_out / p_in, np.nan)


def delivers_power(res: dict) -> np.ndarray:
    """Where power leaves the CVT at one of its shafts (τ_i ω_i < 0 beyond round-off: 1e-9 of the power in)."""
    p1, p2 = res["tau_1"] * res["omega_1"], res["tau_2"] * res["omega_2"]
    with np.errstate(invalid="ignore"):
        return res["ok"] & (-np.minimum(p1, p2) > 1e-9 * np.maximum(np.maximum(p1, p2), 0.0))


@dataclass
class Extreme:
    """Where a figure is taken: its value, the operating point (flat index into the envelope's arrays) and,
    for a contact's figure, the contact (index of the roller); None where no point is ok."""
    value: float | None
    point: int | None = None
    contact: int | None = None


def _extreme(x, mask=None, largest=True, per_contact=False) -> Extreme:
    """The largest (or smallest) finite value of x (points; with `per_contact`, contacts × points) where
    `mask` (points) holds."""
    x = np.asarray(x, float)
    if mask is not None:
        x = np.where(np.broadcast_to(mask, x.shape), x, np.nan)
    if not np.any(np.isfinite(x)):
        return Extreme(None)
    flat = x.reshape(x.shape[0] if per_contact else 1, -1)
    c, k = np.unravel_index(np.nanargmax(flat) if largest else np.nanargmin(flat), flat.shape)
    return Extreme(float(flat[c, k]), int(k), int(c) if per_contact else None)


def _largest_share(e: Extreme, shares) -> Extreme:
    """`e` (a figure summed over the contacts) with the contact whose share (contacts × points) is largest at
    its point."""
    if e.point is None:
        return e
    at = np.abs(np.reshape(shares, (len(shares), -1))[:, e.point])
    return dataclasses.replace(e, contact=int(np.argmax(at)) if np.max(at) > ZERO_TORQUE else None)


def at_key(figure: str) -> str:
    """The JSON key of where a figure is taken: '<figure>_at', with the steering torques' unit left out
    (max_steering_torque_at: the interface outside tools read)."""
    return f"{figure.removesuffix('_Nm') if 'steering_torque' in figure else figure}_at"


def _terms(model: CompiledModel, res: dict) -> dict[str, tuple]:
    """Every extreme figure of the module docstring as (quantity, where it counts, largest, per contact): the
    quantity's points on its last axis (contacts first for a contact's figure); `res` may hold a batch of
    envelopes on the axis before the points (`batch_figures`)."""
    L, deg = model.layout, np.degrees
    G, T = res["gamma_cmd"], res["load"]
    ideal = model.frame.ideal_ratio(G)
    in_range = (np.abs(ideal) >= 0.4) & (np.abs(ideal) <= 2.5)
    at_max = np.isclose(np.abs(T), np.max(np.abs(L.load_grid)))
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio_err = 100 * (ideal - res["omega_2"] / res["omega_1"]) / ideal
    eff_range = (np.abs(G) >= np.radians(5) - 1e-12) & (np.abs(T) >= 0.25 * np.max(np.abs(L.load_grid)))
    delivers = delivers_power(res)
    return {
        "max_abs_alpha_deg": (np.abs(deg(res["alpha"])), None, True, False),
        "max_abs_alpha_steering_deg": (np.abs(deg(res["alpha_steering"])), None, True, False),
        "max_abs_alpha_drive_deg": (np.abs(deg(res["alpha_drive"])), None, True, False),
        "ratio_error_pct_at_max_load": (np.abs(ratio_err), in_range & at_max, True, False),
        "min_efficiency": (res["efficiency"], eff_range & delivers, False, False),
        "max_loss_no_output_W": (res["power_loss"], res["ok"] & ~delivers, True, False),
        "max_traction_utilisation": (res["utilisation"], res["ok"], True, True),
        "max_hertz_pressure_MPa": (res["p_max"] / 1e6, res["ok"], True, True),
        "max_steering_torque_Nm": (np.abs(res["steering_torque"]), res["ok"], True, False),
        "max_standstill_steering_torque_Nm": (res["steering_torque_standstill"], res["ok"], True, False),
    }


def extremes(model: CompiledModel, res: dict) -> dict[str, Extreme]:
    """Every figure of the module docstring that is an extreme over the envelope, with where it is taken (and,
    for the steering torques, the fork whose share is largest there)."""
    out = {k: _extreme(*t) for k, t in _terms(model, res).items()}
    forks = np.reshape([r.fork_ratio for r in model.layout.rollers], (-1, *([1] * res["gamma_cmd"].ndim))) * res["T_fork"]
    out["max_steering_torque_Nm"] = _largest_share(out["max_steering_torque_Nm"], forks)
    k = "max_standstill_steering_torque_Nm"
    out[k] = _largest_share(out[k], res["T_fork_standstill"])
    return out


def batch_figures(model: CompiledModel, res: dict) -> dict[str, np.ndarray]:
    """The values of `metrics`' extremes and RMS α for a batch of envelopes at once (a tolerance study's
    linearised ones): `res` holds every output with the batch on the axis before the points, (batch, points)
    and (contacts, batch, points), and γ, τ⊥, ω1 and ok as (points,). {figure: (batch,)}, NaN where a figure
    has no point (metrics' None), as `metrics` gives them one envelope at a time."""
    missing = not_modelled(model.layout, model.effects)
    out = {}
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)           # an all-NaN batch member: NaN, as wanted
        for k, (x, mask, largest, per_contact) in _terms(model, res).items():
            x = np.asarray(x, float) if mask is None else np.where(mask, x, np.nan)
            axes = (0, x.ndim - 1) if per_contact else (x.ndim - 1,)
            out[k] = np.full(x.shape[-2], np.nan) if k in missing else (np.nanmax if largest else np.nanmin)(x, axis=axes)
        out["rms_alpha_deg"] = np.sqrt(np.nanmean(np.degrees(res["alpha"]) ** 2, axis=-1))
    return out


def where_text(model: CompiledModel, res: dict, e: Extreme) -> dict | None:
    """An Extreme's operating point and contact, for the JSON (`*_at`): γ [°], τ⊥ [N·m], contact name."""
    if e.point is None:
        return None
    g, t = np.ravel(res["gamma_cmd"])[e.point], np.ravel(res["load"])[e.point]
    return {"gamma_deg": round(float(np.degrees(g)), 6), "tau_perp_Nm": round(float(t), 6),
            "contact": None if e.contact is None else model.roller_names[e.contact]}


SPIN_FIGURES = ("max_steering_torque_Nm",)   # figures made of the contacts' spin moments


def not_modelled(layout, effects) -> list[str]:
    """The figures the layout's contact law cannot produce: under a law without spin moment the
    rolling steering torque, whose main part is the spin moment about each fork's axis, is not a 0 but
    not modelled (the ideal CVT, with no effect on, has none to model)."""
    return list(SPIN_FIGURES) if contact_law(layout.contact_law).spin_error is None and effects else []


def metrics(model: CompiledModel, res: dict) -> dict:
    """The figures of merit of an `envelope` result (module docstring), where each extreme is taken
    (`<figure>_at`: γ, τ⊥ and the contact; `not_converged_at`: the points that did not converge), and the
    points' status counts."""
    L = model.layout
    a = np.degrees(res["alpha"])
    ext = extremes(model, res)
    eff_range = (np.abs(res["gamma_cmd"]) >= np.radians(5) - 1e-12) & \
        (np.abs(res["load"]) >= 0.25 * np.max(np.abs(L.load_grid)))
    delivers = delivers_power(res)
    failed = np.flatnonzero(np.ravel(res["status"]) == Status.NOT_CONVERGED)
    missing = not_modelled(L, model.effects)
    return {
        "name": L.name, "file": L.file, "ideal_law": model.frame.law_text(),
        **{k: None if k in missing else e.value for k, e in ext.items()}, "not_modelled": missing,
        "rms_alpha_deg": float(np.sqrt(np.nanmean(a ** 2))) if np.any(np.isfinite(a)) else None,
        "efficiency_points": int(np.sum(eff_range & delivers)),
        "no_output_points": int(np.sum(eff_range & res["ok"] & ~delivers)),
        **{at_key(k): where_text(model, res, e) for k, e in ext.items()},
        "not_converged_at": [where_text(model, res, Extreme(0.0, int(k))) for k in failed],
        **pressure_against_allowable(model, res),
        "points": int(res["status"].size), **status_counts(res, model.roller_names),
    }


def allowable_pressures(layout) -> np.ndarray:
    """Per contact (roller), its allowable Hertz peak pressure [Pa]: the smaller allowable_pressure of the
    roller's and the sphere's materials; NaN where neither gives one (not checked)."""
    return np.array([min((m.p_allow for m in (r.material, layout.sphere_material) if m.p_allow is not None),
                         default=np.nan) for r in layout.rollers], float)


def pressure_against_allowable(model: CompiledModel, res: dict) -> dict:
    """The envelope's Hertz peak pressures against each contact's allowable (module docstring)."""
    L = model.layout
    allow = allowable_pressures(L).reshape(-1, *([1] * (res["p_max"].ndim - 1)))
    with np.errstate(invalid="ignore"):
        ratio = res["p_max"] / allow
    if not np.any(np.isfinite(ratio)):
        return {"max_hertz_pressure_over_allowable": None, "hertz_allowable_pressure_MPa": None,
                "hertz_over_allowable_at": {}}
    worst = int(np.nanargmax(np.nanmax(ratio.reshape(len(L.rollers), -1), axis=1)))
    over = {n: int(k) for n, k in zip(model.roller_names, np.sum(ratio > 1, axis=tuple(range(1, ratio.ndim)))) if k}
    return {"max_hertz_pressure_over_allowable": bool(over),
            "hertz_allowable_pressure_MPa": float(allow.ravel()[worst]) / 1e6, "hertz_over_allowable_at": over}
