"""Variant files (YAML) → a validated, SI-valued `Layout` (core.layout) that the model compiler reads.

The schema (io.schema) fixes the fields and io.yaml_file reads the file with limits; here every value is
converted to SI (io.units), checked against the range that is plausible for this machine (PLAUSIBLE) and
assembled into a Layout. Geometric checks (core.checks: axle ⊥ normal, contact points on the sphere, preloads
that balance, overlapping rollers, steering that cannot fix an axis, couplings that fight) then run on it.
Every problem is one `InputError` line naming the file and the field.

Plain numbers are SI. Rather than requiring units on every dimensional field, each value is checked against
its plausible range, however it was written, and a plain number outside it is refused with the unit it
probably meant ("rollers.D1.radius: 45 m is not a plausible roller radius (expected at most 1 m); did you
mean '45 mm'?"). docs/variant-reference.md lists the ranges.
"""
from __future__ import annotations

import dataclasses
import json
import math
import re

import casadi as ca
import numpy as np

from cvtdesign.core import effects as fx
from cvtdesign.core.contact import laws
from cvtdesign.core.checks import check_layout
from cvtdesign.core.geometry import KIM_FRAME, named_vector, spherical
from cvtdesign.core.layout import Frame, Layout, Material, Roller
from cvtdesign.errors import InputError, shorten, suggest
from cvtdesign.io import materials
from cvtdesign.io.limits import MAX_GRID_POINTS, check_envelope_limits
from cvtdesign.io.schema import RangeSpec, Spherical, VariantSpec
from cvtdesign.io.units import (
    MAX_QUANTITY_TEXT,
    Parameters,
    check_range,
    evaluate_expression,
    parse_quantity,
    registry,
    to_si,
)
from cvtdesign.io.yaml_file import read_spec

def vector(spec, where, names, point=False):
    """A unit direction from a frame name, {polar, azimuth} or a list of three numbers or '= expressions'
    (dimensionless, over the file's parameters; CasADi expressions when the optimiser makes them symbolic)."""
    if isinstance(spec, str):
        v = named_vector(spec.strip())
        if v is None:
            forms = "a list of 3 numbers, a point of 3 lengths" if point else "a list of 3 numbers"
            raise InputError(f"{where}: expected a frame vector name (x, y, z, d1, d2, c1, c2, c3, optionally "
                             f"with '-'), {forms} or {{polar, azimuth}}, got '{spec}'")
        return v
    if isinstance(spec, Spherical):
        return spherical(quantity(spec.polar, "direction_angle", f"{where}.polar", names),
                         quantity(spec.azimuth, "direction_angle", f"{where}.azimuth", names))
    if len(spec) != 3:
        raise InputError(f"{where}: expected a non-zero vector of 3 finite numbers, got {shorten(spec)}")
    parts = [to_si(c, "dimensionless", f"{where}[{i}]", names) if isinstance(c, str) else c for i, c in enumerate(spec)]
    if not all(isinstance(c, (int, float)) for c in parts):         # symbolic design parameters
        v = ca.vertcat(*parts)
        return v / ca.norm_2(v)
    v = np.asarray(parts, dtype=float)
    if not np.all(np.isfinite(v)) or not np.any(v):
        raise InputError(f"{where}: expected a non-zero vector of 3 finite numbers, got {shorten(spec)}")
    norm = np.linalg.norm(v)
    if not (np.isfinite(norm) and norm > 0):     # [1e308, 1e308, 0] or [1e-320, 0, 0]: scale first
        v = v / np.max(np.abs(v))
        norm = np.linalg.norm(v)
    return v / norm


def _contact(spec, where, names, R):
    """The unit contact normal of a roller's `contact` (see RollerSpec): a direction as `vector` reads it
    (plain numbers and '= expressions'), or a point when an entry is a length with its unit ('44.9 mm'; the
    others lengths too, or '= expressions' in m), which must lie on the sphere of radius R (checked when
    both are numbers; an optimiser's symbolic parameters skip the check). A list of expressions alone is a
    direction: as a point on the sphere it would give the same normal."""
    if not isinstance(spec, list):
        return vector(spec, where, names, point=True)
    length = [isinstance(c, str) and not c.strip().startswith("=") for c in spec]
    if not any(length):
        return vector(spec, where, names, point=True)
    if not all(isinstance(c, str) for c in spec):
        raise InputError(f"{where}: mixes plain numbers and lengths ({', '.join(map(str, spec))}); give a direction "
                         "(plain numbers or '= expressions') or a point of three lengths like '44.9 mm'")
    if len(spec) != 3:
        raise InputError(f"{where}: expected a point of 3 lengths, got {len(spec)}")
    p = [to_si(c, "length", f"{where}[{i}]", names) for i, c in enumerate(spec)]
    if not all(isinstance(c, float) for c in p):
        p = ca.vertcat(*p)
        return p / ca.norm_2(p)
    p = np.array(p)
    dist = float(np.linalg.norm(p))
    if isinstance(R, float) and not abs(dist - R) <= 1e-6 * R:
        raise InputError(f"{where}: the contact point is {dist * 1e3:.6g} mm from the sphere centre but the sphere "
                         f"radius is {R * 1e3:.6g} mm; a contact point must lie on the sphere (three plain numbers "
                         "give a direction instead)")
    if dist == 0:
        raise InputError(f"{where}: the contact point is the sphere centre; a contact point must lie on the sphere")
    return p / dist


def _positive(value, where, what="a positive value"):
    if isinstance(value, float) and not value > 0:
        raise InputError(f"{where}: expected {what}, got {value:g}")
    return value


# plausible SI range of each dimensional field: (what, kind, lower, upper, lower exclusive, unit a plain number
# probably meant); see VariantSpec
PLAUSIBLE = {
    # lengths below a tenth of a millimetre are no machine part (a 1e-6 mm roller would give 5947 MPa)
    "sphere_radius": ("sphere radius", "length", 1e-3, 2.0, False, "mm"),
    "roller_radius": ("roller radius", "length", 1e-4, 1.0, False, "mm"),
    "crown_radius": ("crown radius", "length", 1e-4, 1.0, False, "mm"),
    "width": ("roller width", "length", 1e-4, 1.0, False, "mm"),
    "preload": ("preload", "force", 0.0, 1e5, True, None),
    "mount_stiffness": ("mount stiffness", "stiffness", 0.0, 1e10, True, None),
    "youngs_modulus": ("Young's modulus", "pressure", 1e5, 1.2e12, False, "MPa"),
    "friction": ("friction coefficient", "dimensionless", 0.0, 3.0, True, None),
    "allowable_pressure": ("allowable pressure", "pressure", 1e4, 1e11, False, "MPa"),
    "creep": ("creep constant", "compliance", 0.0, 1.0, True, None),
    "creep_reference_force": ("creep reference force", "force", 0.0, 1e5, True, None),
    "calibration": ("calibration factor", "dimensionless", 0.0, 100.0, True, None),
    "direction_angle": ("direction angle", "angle", -2 * math.pi, 2 * math.pi, False, "deg"),
    "gamma": ("transmission angle γ", "angle", -math.pi, math.pi, False, "deg"),
    "load": ("load", "torque", -1e4, 1e4, False, None),
    "motor_speed": ("motor speed", "speed", 0.0, 1e4, True, None),
    "frame_distance": ("plate distance", "length", 0.0, 10.0, True, "mm"),
    "frame_thickness": ("plate thickness", "length", 0.0, 1.0, True, "mm"),
}
_EFFECT_GUESS = {"length": "mm", "angle": "deg"}


def quantity(raw, key: str, where: str, names: dict | None = None, positive: str | None = None):
    """A dimensional field of PLAUSIBLE[key] in SI: finite (to_si), with `positive` ('a positive radius') the
    message for a value ≤ 0, then within the plausible range."""
    what, kind, lo, hi, lo_open, guess = PLAUSIBLE[key]
    value = to_si(raw, kind, where, names)
    if positive:
        _positive(value, where, positive)
    value = check_range(value, raw, where, what, kind, lo, hi, lo_open=lo_open, guess=guess)
    if key == "gamma":
        _not_singular(value, where)
    return value


def _not_singular(gamma, where: str) -> None:
    """γ [rad] clear of ±90° (mod 180°): there the sphere's axis is square to the motor's shaft (1), whose
    roller then cannot turn it, and the ideal ratio k(c + s tan γ) is infinite (docs/conventions.md). Every
    point there would be left not converged."""
    if isinstance(gamma, (int, float)) and abs(math.cos(gamma)) < 1e-9:
        raise InputError(f"{where}: γ = {math.degrees(gamma):g} deg is where the sphere's axis is square to the "
                         "motor's shaft 1, which then cannot turn it (the ideal ratio is infinite); expected a γ "
                         "clear of ±90 deg")


def effect_value(effect: str, param: str, raw, where: str, names: dict | None = None):
    """An effect parameter in SI, finite and within the bounds of its `effects.Param` (the lower one exclusive
    for a `positive` parameter: zero would switch the effect off or be unphysical); docs/effects.md lists them."""
    spec = fx.EFFECTS[effect].params[param]
    value = to_si(raw, spec.kind, where, names)
    lo = spec.lower if math.isfinite(spec.lower) else None
    hi = spec.upper if math.isfinite(spec.upper) else None
    return check_range(value, raw, where, f"{effect}.{param}", spec.kind, lo, hi,
                       lo_open=spec.positive, guess=_EFFECT_GUESS.get(spec.kind))


def grid(r: RangeSpec, kind, where):
    """The points start, start + step, ..., stop of an envelope axis (kind 'angle': γ, 'torque': the load)."""
    key = {"angle": "gamma", "torque": "load"}.get(kind)
    a, b = ((quantity(getattr(r, k), key, f"{where}.{k}") if key else to_si(getattr(r, k), kind, f"{where}.{k}"))
            for k in ("start", "stop"))
    s = to_si(r.step, kind, f"{where}.step")
    if not s > 0 or b < a:
        raise InputError(f"{where}: expected start <= stop and step > 0")
    if not (b - a) / s <= MAX_GRID_POINTS - 1:
        raise InputError(f"{where}.step: a step of {s:.3g} gives {(b - a) / s + 1:.3g} points from start to stop; "
                         f"expected at most {MAX_GRID_POINTS} points per envelope axis (a larger step)")
    points = np.linspace(a, b, int(round((b - a) / s)) + 1)
    singular = np.flatnonzero(np.abs(np.cos(points)) < 1e-9) if kind == "angle" else []
    if len(singular):
        _not_singular(float(points[singular[0]]), f"{where}: point {singular[0]}")
    return points


def resolve(spec: VariantSpec, where: str, overrides: dict | None = None) -> Layout:
    """Build the SI Layout. `overrides` maps parameter names to values (floats or CasADi symbols)."""
    names, overrides = Parameters(), overrides or {}
    for k, v in spec.parameters.items():   # in order, so later parameters may use earlier ones
        names[k] = overrides[k] if k in overrides else parameter_value(v, f"{where}: parameters.{k}", names)
        names.record(k, v)
    mats = _materials(spec, where, names)
    R = quantity(spec.sphere.radius, "sphere_radius", f"{where}: sphere.radius", names, "a positive radius")
    forks, fork_of = _forks(spec, where, names)
    law, calibration = _contact_law(spec, where, names)
    sphere_material = _material(mats, spec.sphere.material, f"{where}: sphere.material")
    rollers = tuple(_with_creep_source(_roller(spec, rn, where, names, mats, fork_of, R), spec, where)
                    for rn in spec.rollers)
    for s in (1, 2):
        if not any(r.role == "drive" and r.shaft == s for r in rollers):
            raise InputError(f"{where}: rollers: no drive roller on shaft {s} (role: drive, shaft: {s})")
    laws.check_effects(spec.effects, f"{where}: effects", law)
    eparams = _effect_parameters(spec, where, names)
    c, env = spec.contact, spec.envelope

    def creep(value, key, field):
        return None if value is None else quantity(value, key, f"{where}: contact.{field}", names, "a positive value")

    layout = Layout(
        name=spec.name, file=where, sphere_radius=R,
        sphere_material=sphere_material, rollers=rollers,
        creep_drive=creep(c.creep_drive, "creep", "creep_drive"),
        creep_steering=creep(c.creep_steering, "creep", "creep_steering"),
        creep_reference_force=creep(c.creep_reference_force, "creep_reference_force", "creep_reference_force"),
        effects=tuple(spec.effects), effect_parameters=eparams,
        effect_uncertainty=_effect_parameters(spec, where, names, "effect_uncertainty"),
        gamma_grid=grid(env.gamma, "angle", f"{where}: envelope.gamma"),
        load_grid=grid(env.load, "torque", f"{where}: envelope.load"),
        motor_speed=quantity(env.motor_speed, "motor_speed", f"{where}: envelope.motor_speed", None, "a positive value"),
        parameters=names, contact_law=law, calibration=calibration, forks=forks,
        frame=None if spec.frame is None else _frame(spec.frame, f"{where}: frame", names),
        calibration_machine=spec.calibration_machine,
        preload_std=DEFAULT_STD["preload"] if spec.preload_std is None else
        relative_std(spec.preload_std, f"{where}: preload_std"), preload_std_assumed=spec.preload_std is None,
        kim_vectors=_kim_vectors(spec))
    check_envelope_limits(layout, f"{where}: envelope")
    return layout


def _contact_law(spec: VariantSpec, where: str, names: dict) -> tuple[str, dict]:
    """contact.law and its calibration factors: a law that takes fitted creep constants refuses calibration
    factors, one that takes factors refuses fitted constants (one InputError line each)."""
    c, law, w = spec.contact, laws.contact_law(spec.contact.law), f"{where}: contact"
    if law.fitted:
        if c.calibration != type(c.calibration)():
            raise InputError(f"{w}.calibration: applies to a law on a theory's compliances, not to law {law.name} "
                             f"({law.title}); expected contact.law: {' or '.join(laws.names_where(fitted=False))} "
                             "with it, or no calibration (creep_drive and creep_steering instead)")
        return law.name, {"drive": 1.0, "steering": 1.0}
    for f in ("creep_drive", "creep_steering", "creep_reference_force"):
        if getattr(c, f) is not None:
            raise InputError(f"{w}.{f}: a fitted creep constant belongs to a law with fitted constants "
                             f"({' or '.join(laws.names_where(fitted=True))}); under law {law.name} the contacts "
                             f"follow {law.title}, scaled by contact.calibration: {{drive, steering}}")
    factors = {k: getattr(c.calibration, k) for k in ("drive", "steering")}
    return law.name, {k: 1.0 if v is None else quantity(v, "calibration", f"{w}.calibration.{k}", names,
                                                        "a positive factor") for k, v in factors.items()}


def _materials(spec: VariantSpec, where: str, names: dict) -> dict:
    """name → Material of every material the variant can name: its own, then the library's (io.materials)."""
    mats = {}
    for k, (m, w) in materials.material_specs(where, spec).items():
        mats[k] = Material(
            E=quantity(m.youngs_modulus, "youngs_modulus", f"{w}.youngs_modulus", names, "a positive value"),
            nu=to_si(m.poisson_ratio, "dimensionless", f"{w}.poisson_ratio", names),
            p_allow=None if m.allowable_pressure is None else quantity(
                m.allowable_pressure, "allowable_pressure", f"{w}.allowable_pressure", names, "a positive pressure"),
            name=k, E_std=DEFAULT_STD["modulus"] if m.youngs_modulus_std is None else
            relative_std(m.youngs_modulus_std, f"{w}.youngs_modulus_std"), E_std_assumed=m.youngs_modulus_std is None)
        if m.friction is not None:
            raise InputError(f"{w}.friction: friction belongs to a pair of materials, not to one; expected it under "
                             f"pairs: [{{materials: [{k}, OTHER], friction: μ, range: [low, high], source: ...}}] "
                             "(docs/materials.md, 'Friction')")
        if isinstance(mats[k].nu, float) and not 0 <= mats[k].nu < 0.5:
            raise InputError(f"{w}.poisson_ratio: expected 0 <= ν < 0.5, got {mats[k].nu:g}")
    return mats


DEFAULT_STD = {"modulus": 0.25, "preload": 0.20}   # assumed where a file states none (io.schema's descriptions)


def relative_std(value, where: str) -> float:
    """A relative 1σ as written ('25 %', 0.25): finite, above 0 and below 1, else one InputError line."""
    s = to_si(value, "dimensionless", where)
    if not (isinstance(s, float) and 0 < s < 1):
        raise InputError(f"{where}: expected a relative standard deviation above 0 and below 100 %, got {value}")
    return s


def _with_creep_source(roller: Roller, spec: VariantSpec, where: str) -> Roller:
    """The roller with where its creep compliance comes from (io.materials.contact_calibration) and its pair's
    friction (io.materials.pair_friction)."""
    material, _ = _own_or_default(spec, roller.name, "material", where)
    materials.check_fitted_pair(where, spec, roller.name, roller.role, material, spec.sphere.material)
    return dataclasses.replace(roller, friction=materials.pair_friction(where, spec, roller.name, material,
                                                                        spec.sphere.material),
                               creep=materials.contact_calibration(where, spec, roller.role, material,
                                                                   spec.sphere.material))


def _material(mats: dict, name: str, where: str) -> Material:
    if name not in mats:
        raise InputError(f"{where}: unknown material '{name}'{suggest(name, mats)}")
    return mats[name]


def _fork_ratio(f, w: str, names: dict) -> float:
    """A fork's gear ratio: its `ratio` (a number, 0.01 ≤ |ratio| ≤ 100), else its `sign`, else 1."""
    if f.ratio is not None and f.sign is not None:
        raise InputError(f"{w}: gives both ratio and sign; expected one of them (sign: -1 is ratio: -1)")
    if f.ratio is None:
        return float(1 if f.sign is None else f.sign)
    ratio = to_si(f.ratio, "dimensionless", f"{w}.ratio", names)
    if not isinstance(ratio, float):
        raise InputError(f"{w}.ratio: depends on a design variable; expected a fixed number (a linkage's gear "
                         "ratio changes no figure, only how far the forks turn)")
    if not 1e-2 <= abs(ratio) <= 1e2:
        raise InputError(f"{w}.ratio: {ratio:g} is not a plausible fork gear ratio (expected 0.01 <= |ratio| <= 100)")
    return ratio


def _forks(spec: VariantSpec, where: str, names: dict) -> tuple[tuple[tuple[str, ...], ...], dict]:
    """Each fork's rollers, and steering roller name -> (fork axis, gear ratio, index of its fork)."""
    forks, fork_of = [], {}
    for i, f in enumerate(spec.steering.forks):
        w = f"{where}: steering.forks[{i}]"
        axis = vector(f.axis, f"{w}.axis", names)
        ratio = _fork_ratio(f, w, names)
        if not f.rollers:
            raise InputError(f"{w}.rollers: empty; every fork holds at least one roller (a steering roller's name)")
        for rn in f.rollers:
            if rn not in spec.rollers:
                raise InputError(f"{w}.rollers: unknown roller '{rn}'{suggest(rn, spec.rollers)}")
            if spec.rollers[rn].role != "steering":
                raise InputError(f"{w}.rollers: '{rn}' is a {spec.rollers[rn].role} roller; only steering rollers turn with φ")
            if rn in fork_of:
                raise InputError(f"{w}.rollers: '{rn}' is already on another fork")
            fork_of[rn] = (axis, ratio, i)
        forks.append(tuple(f.rollers))
    return tuple(forks), fork_of


def _frame(f, w: str, names: dict) -> Frame:
    """The mounting plate `frame` in SI (drawn by `cvtdesign export` only, checked here with the rest)."""
    return Frame(side=vector(f.side, f"{w}.side", names),
                 distance=quantity(f.distance, "frame_distance", f"{w}.distance", names, "a positive distance"),
                 thickness=quantity(f.thickness, "frame_thickness", f"{w}.thickness", names, "a positive thickness"))


def _kim_vectors(spec: VariantSpec) -> tuple[str, ...]:
    """The names of Kim's frame vectors that the variant file writes in its rollers or forks ('d1', '-c2')."""
    text = json.dumps([spec.model_dump(mode="json")[k] for k in ("rollers", "steering")])
    return tuple(k for k in KIM_FRAME if re.search(rf"(?<![\w.]){k}(?!\w)", text))


def _own_or_default(spec: VariantSpec, rn: str, field: str, where: str):
    """A roller's own value of `field` and the field's name in messages, else roller_defaults' value."""
    own = getattr(spec.rollers[rn], field)
    if own is not None:
        return own, f"{where}: rollers.{rn}.{field}"
    value = getattr(spec.roller_defaults, field)
    if value is None:
        raise InputError(f"{where}: rollers.{rn}.{field}: missing (give it on the roller or in roller_defaults)")
    return value, f"{where}: roller_defaults.{field}"


def _roller(spec: VariantSpec, rn: str, where: str, names: dict, mats: dict, forks: dict, R) -> Roller:
    r, w = spec.rollers[rn], f"{where}: rollers.{rn}"
    if r.role in ("drive", "follower") and r.shaft is None:
        raise InputError(f"{w}.shaft: missing (a {r.role} roller must name shaft 1 or 2)")
    if r.role == "steering" and r.shaft is not None:
        raise InputError(f"{w}.shaft: a steering roller is an idler and has no shaft")
    if r.role == "steering" and rn not in forks:
        raise InputError(f"{w}: steering roller is on no fork (steering.forks[].rollers)")

    def field(name, key, what="a positive value"):
        value, at = _own_or_default(spec, rn, name, where)
        return quantity(value, key, at, names, what)

    radius = field("radius", "roller_radius", "a positive radius")
    has_crown = r.crown_radius is not None or spec.roller_defaults.crown_radius is not None
    normal = _contact(r.contact, f"{w}.contact", names, R)
    axle = vector(r.axle, f"{w}.axle", names)
    _check_perpendicular(normal, axle, f"{w}.axle")
    ratio = to_si(r.ratio, "dimensionless", f"{w}.ratio", names)
    if isinstance(ratio, float) and ratio == 0:
        raise InputError(f"{w}.ratio: expected a non-zero coupling ratio")
    if isinstance(ratio, float) and not 1e-3 <= abs(ratio) <= 1e3:
        raise InputError(f"{w}.ratio: {ratio:g} is not a plausible coupling ratio (expected 1e-3 <= |ratio| <= 1e3)")
    material, at = _own_or_default(spec, rn, "material", where)
    axis, fork_ratio, fork = forks.get(rn, (None, 0.0, None))
    return Roller(
        name=rn, role=r.role, shaft=r.shaft, ratio=ratio if r.role == "follower" else 1.0,
        normal=normal, axle=axle, radius=radius,
        crown_radius=field("crown_radius", "crown_radius", "a positive radius") if has_crown else radius,
        width=field("width", "width"), material=_material(mats, material, at),
        preload=field("preload", "preload"), stiffness=field("mount_stiffness", "mount_stiffness"),
        fork_axis=axis, fork_ratio=fork_ratio, fork=fork)


def _check_perpendicular(normal, axle, where: str):
    dot = ca.dot(ca.vec(ca.DM(normal) if isinstance(normal, np.ndarray) else normal),
                 ca.vec(ca.DM(axle) if isinstance(axle, np.ndarray) else axle))
    if isinstance(dot, (ca.DM, float)) and abs(float(dot)) > 1e-6:
        raise InputError(f"{where}: not perpendicular to the contact normal (axle·normal = {float(dot):.4g}); "
                         "the axle must lie in the sphere's tangent plane at the contact")


def _effect_parameters(spec: VariantSpec, where: str, names: dict, key: str = "effect_parameters") -> dict:
    """effect → {parameter: SI value} of the variant's `key` (effect_parameters, or effect_uncertainty: their σ)."""
    eparams = {}
    for e, ps in getattr(spec, key).items():
        if e not in fx.EFFECTS:
            raise InputError(f"{where}: {key}.{e}: unknown effect{suggest(e, fx.EFFECTS)}")
        eparams[e] = {}
        for p, v in ps.items():
            known = fx.EFFECTS[e].params
            if p not in known:
                raise InputError(f"{where}: {key}.{e}.{p}: unknown parameter{suggest(p, known)}")
            eparams[e][p] = effect_value(e, p, v, f"{where}: {key}.{e}.{p}", names)
    return eparams


def parameter_value(v, where, names):
    """A named parameter: any finite quantity with units (kept in SI), a plain number (SI) or an expression
    over earlier parameters."""
    if isinstance(v, bool) or v is None:
        raise InputError(f"{where}: expected a number or a quantity like '60 mm', got {str(v).lower()}")
    if isinstance(v, (int, float)):
        return to_si(v, "dimensionless", where)
    text = str(v).strip()
    if text.startswith("="):
        return evaluate_expression(text[1:].strip(), names, where)
    q = parse_quantity(text) if len(text) <= MAX_QUANTITY_TEXT else None
    value = None
    if q is not None:
        try:
            value = q[0] if q[1] is None else float(registry().Quantity(q[0], q[1]).to_base_units().magnitude)
        except (ValueError, TypeError, AttributeError, AssertionError, OverflowError):
            value = None
    if value is None:
        raise InputError(f"{where}: expected a number or a quantity like '60 mm', got '{shorten(v)}'")
    if not math.isfinite(value):
        raise InputError(f"{where}: expected a finite number or quantity like '60 mm', got '{shorten(v)}'")
    return value


def load_spec(path) -> VariantSpec:
    return read_spec(path, VariantSpec, "name, materials, sphere, rollers, steering")


def load_variant(path, overrides: dict | None = None, check: bool = True) -> Layout:
    """Read, validate and resolve a variant file; with `check`, run the geometric checks too."""
    layout = resolve(load_spec(path), str(path), overrides)
    if check:
        check_layout(layout)
    return layout
