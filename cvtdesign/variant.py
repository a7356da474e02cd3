"""Variant files (YAML) → a validated, SI-valued `Layout` that the model compiler reads.

The schema (pydantic) fixes the fields; `load_variant` turns every problem into one `InputError` line
naming the file and the field. Geometric checks (axle ⊥ normal, contact points on the sphere, preloads that
balance, overlapping rollers, steering that cannot fix an axis, couplings that fight) run on the resolved layout.

The file itself is read with limits (`read_spec`): at most MAX_FILE_BYTES, UTF-8, YAML nested at most
MAX_NESTING deep, no duplicate keys (PyYAML would let the last one silently win), aliases expanding to at most
MAX_NODES nodes.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Annotated, Literal, Union

import casadi as ca
import numpy as np
import yaml
from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, ValidationError
from pydantic_core import PydanticCustomError

from . import effects as fx
from .geometry import named_vector, spherical
from .units import InputError, check_range, shorten, suggest, to_si


def _no_bool(v):
    """YAML's true/false are not numbers (pydantic would read `radius: true` as 1, a 1 m sphere)."""
    if isinstance(v, bool):
        raise PydanticCustomError("bool_not_number", "expected a number or a quantity like '40 mm', got {value} "
                                  "(true/false are not numbers)", {"value": str(v).lower()})
    return v


def _file_name(v):
    """A variant's or study's `name` becomes part of file names (<name>.step, <name>_<study>.yaml,
    results/<study>/): letters, digits, '_', '.', '+', '-', not starting with '.', at most 100 characters."""
    if not re.fullmatch(r"[A-Za-z0-9_+\-][A-Za-z0-9_.+\-]{0,99}", v):
        raise PydanticCustomError("file_name", "expected a name of letters, digits, '_', '.', '+' or '-' (it becomes "
                                  "part of file names), got '{value}'", {"value": shorten(v)})
    return v


Name = Annotated[str, AfterValidator(_file_name)]
Num = Annotated[Union[float, int, str], BeforeValidator(_no_bool)]   # a plain number (SI), a quantity or '= expr'
Coord = Annotated[float, BeforeValidator(_no_bool)]                   # a component of a direction
VectorSpec = Union[str, list[Coord], "Spherical"]


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class Spherical(Strict):
    polar: Num
    azimuth: Num


class MaterialSpec(Strict):
    youngs_modulus: Num
    poisson_ratio: Num
    friction: Num = 0.8
    allowable_pressure: Num | None = None


class SphereSpec(Strict):
    radius: Num
    material: str


class RollerSpec(Strict):
    """One roller. `contact` is where it touches the sphere, given as a direction from the sphere centre
    (a frame name such as 'd2' or '-c1', a list of three plain numbers, normalised, or {polar, azimuth}) or
    as a point: a list of three lengths (e.g. ["0 mm", "0 mm", "63.5 mm"] or "= expressions" over the
    parameters, in m), which must lie on the sphere (|p| = sphere radius within 1e-6 relative). Plain
    numbers are always a direction, never a point; a list mixing plain numbers and lengths is refused.
    `axle` is the positive spin axis, perpendicular to the contact normal."""
    role: Literal["drive", "follower", "steering"]
    contact: Union[str, list[Num], Spherical]
    axle: Union[str, list[Coord], Spherical]
    radius: Num
    material: str
    crown_radius: Num | None = None
    width: Num = "24 mm"
    shaft: Annotated[Literal[1, 2] | None, BeforeValidator(_no_bool)] = None
    ratio: Num = 1.0
    preload: Num | None = None
    mount_stiffness: Num | None = None


class RollerDefaults(Strict):
    preload: Num = "100 N"
    mount_stiffness: Num = "2e5 N/m"


class ForkSpec(Strict):
    rollers: list[str]
    axis: Union[str, list[Coord], Spherical]
    sign: Annotated[Literal[1, -1], BeforeValidator(_no_bool)] = 1


class SteeringSpec(Strict):
    forks: list[ForkSpec]


class ContactSpec(Strict):
    creep_drive: Num | None = None
    creep_steering: Num | None = None
    creep_reference_force: Num | None = None   # normal force at which the creep constants hold (default: preload)


class RangeSpec(Strict):
    start: Num
    stop: Num
    step: Num


class EnvelopeSpec(Strict):
    gamma: RangeSpec = RangeSpec(start="-80 deg", stop="80 deg", step="10 deg")
    load: RangeSpec = RangeSpec(start="-1 N*m", stop="1 N*m", step="0.1 N*m")
    motor_speed: Num = "10 rad/s"


class FrameSpec(Strict):
    """A mounting plate, drawn by `cvtdesign export` only: perpendicular to `side` (a vector from the sphere
    centre), its near face `distance` from the centre, sized to the assembly's outline."""
    side: Union[str, list[Coord], Spherical]
    distance: Num
    thickness: Num = "10 mm"


class VariantSpec(Strict):
    """A variant file.

    Units: a quantity is a number with a unit ("40 mm", "100 N", "10.7 MPa", "10 deg"); a plain number is
    SI (m, N, Pa, N/m, 1/N, rad, N·m, rad/s); "= expr" is evaluated in SI. Plain numbers stay allowed (the
    files and the command line have always read them as SI), so instead of requiring units every value is
    checked against the range that is plausible for this machine, whatever way it was written, and a plain
    number outside it gets the unit it probably meant: "rollers.D1.radius: 45 m is not a plausible roller
    radius (expected at most 1 m); did you mean '45 mm'?". The ranges (SI; `PLAUSIBLE`):
    sphere radius 0 < R ≤ 2 m; roller radius, crown radius and width 0 < r ≤ 1 m; preload 0 < P ≤ 1e5 N;
    mount stiffness 0 < k ≤ 1e10 N/m; Young's modulus 0.1 MPa ≤ E ≤ 1200 GPa; Poisson's ratio 0 ≤ ν < 0.5;
    friction 0 < μ ≤ 3; allowable pressure 10 kPa ≤ p ≤ 100 GPa; creep constants 0 < ε ≤ 1 1/N; creep
    reference force 0 < N ≤ 1e5 N; follower ratio 1e-3 ≤ |ratio| ≤ 1e3; contact polar/azimuth angles
    |θ| ≤ 360°; envelope γ within ±180° (relabelled shafts put Kim's γ at 10°..170°), load |τ| ≤ 1e4 N·m,
    at most MAX_GRID_POINTS points per axis, motor speed 0 < ω ≤ 1e4 rad/s; frame distance 0 < d ≤ 10 m,
    thickness 0 < t ≤ 1 m;
    effect parameters within their `effects.Param` bounds, and above 0 for `POSITIVE_EFFECT_PARAMS`. Every
    value must be finite; named `parameters` are any finite quantity (their use is checked where they land)."""
    name: Name
    description: str = ""
    parameters: dict[str, Num] = {}
    materials: dict[str, MaterialSpec]
    sphere: SphereSpec
    roller_defaults: RollerDefaults = RollerDefaults()
    rollers: dict[str, RollerSpec]
    steering: SteeringSpec
    contact: ContactSpec = ContactSpec()
    effects: list[str] = ["drive_longitudinal_creep", "steering_lateral_creep"]
    effect_parameters: dict[str, dict[str, Num]] = {}
    envelope: EnvelopeSpec = EnvelopeSpec()
    frame: FrameSpec | None = None


@dataclass(frozen=True)
class Material:
    E: object          # Young's modulus [Pa]
    nu: object         # Poisson's ratio [-]
    mu: object         # friction coefficient [-]
    p_allow: object    # allowable Hertz peak pressure [Pa] (None: not checked)


@dataclass(frozen=True)
class Roller:
    """One roller in SI; numeric fields are floats or CasADi expressions of design parameters."""
    name: str
    role: str                      # 'drive' | 'follower' | 'steering'
    shaft: int | None              # 1 or 2 for drive/follower rollers
    ratio: object                  # roller speed / shaft speed [-]
    normal: object                 # unit contact normal at φ = 0 (3-vector)
    axle: object                   # unit positive spin axis at φ = 0 (3-vector, ⊥ normal)
    radius: object                 # rolling radius [m]
    crown_radius: object           # crown radius [m]
    width: object                  # [m]
    material: Material
    preload: object                # normal force with the sphere centred [N]
    stiffness: object              # mount + contact normal stiffness [N/m]
    fork_axis: object = None       # steering fork axis through the sphere centre (unit), None if fixed
    fork_sign: int = 0


@dataclass(frozen=True)
class Layout:
    """A resolved variant: what the compiler needs, in SI."""
    name: str
    file: str
    sphere_radius: object
    sphere_material: Material
    rollers: tuple[Roller, ...]
    creep_drive: object            # ε_D at the preload [1/N] or None (Hertz + Kalker)
    creep_steering: object         # ε_S at the preload [1/N] or None
    creep_reference_force: object  # normal force [N] at which ε_D, ε_S hold; None: each roller's preload
    effects: tuple[str, ...]
    effect_parameters: dict        # effect -> {param: SI value}
    gamma_grid: np.ndarray         # [rad]
    load_grid: np.ndarray          # [N m]
    motor_speed: float             # [rad/s]
    parameters: dict = field(default_factory=dict)
    spec: VariantSpec | None = None

    def with_effects(self, effects, parameters=None) -> "Layout":
        params = {k: dict(v) for k, v in self.effect_parameters.items()}
        for k, v in (parameters or {}).items():
            params.setdefault(k, {}).update(v)
        return replace(self, effects=tuple(effects), effect_parameters=params)


def _schema_error(err: ValidationError, where: str, root=None) -> InputError:
    # an unknown (misspelt) field explains the 'missing' error that comes with it: report it first
    e = sorted(err.errors(), key=lambda x: x["type"] != "extra_forbidden")[0]
    loc = [str(p) for p in e["loc"]]
    # pydantic lists union branches in loc (e.g. 'str', 'list[float]'): drop them
    loc = [p for p in loc if not (p in ("str", "float", "int", "Spherical", "bool", "none") or
                                  p.startswith(("list[", "literal[", "function-", "dict[", "union[", "nullable[")))]
    path = ".".join(loc)
    if e["type"] == "extra_forbidden":
        model = root or VariantSpec
        for p in loc[:-1]:
            ann = model.model_fields.get(p) if isinstance(model, type) and issubclass(model, BaseModel) else None
            if ann is None:
                continue
            t = ann.annotation
            args = getattr(t, "__args__", ())
            model = next((a for a in (t, *args) if isinstance(a, type) and issubclass(a, BaseModel)), model)
        known = model.model_fields if isinstance(model, type) and issubclass(model, BaseModel) else {}
        return InputError(f"{where}: {path}: unknown field{suggest(loc[-1], known)}")
    if e["type"] == "missing":
        return InputError(f"{where}: {path}: missing required field")
    return InputError(f"{where}: {path}: {e['msg'].lower()}")


def _vector(spec, where, names, point=False):
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
    v = np.asarray(spec, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)) or not np.any(v):
        raise InputError(f"{where}: expected a non-zero vector of 3 finite numbers, got {shorten(spec)}")
    norm = np.linalg.norm(v)
    if not (np.isfinite(norm) and norm > 0):     # [1e308, 1e308, 0] or [1e-320, 0, 0]: scale first
        v = v / np.max(np.abs(v))
        norm = np.linalg.norm(v)
    return v / norm


def _contact(spec, where, names, R):
    """The unit contact normal of a roller's `contact` (see RollerSpec): a direction as `_vector` reads it,
    or a point of three lengths, which must lie on the sphere of radius R (checked when both are numbers;
    an optimiser's symbolic parameters skip the check)."""
    if not isinstance(spec, list):
        return _vector(spec, where, names, point=True)
    quantity = [isinstance(c, str) for c in spec]
    if not any(quantity):
        return _vector(spec, where, names, point=True)
    if not all(quantity):
        raise InputError(f"{where}: mixes plain numbers and quantities ({', '.join(map(str, spec))}); give three "
                         "plain numbers (a direction) or three lengths like '44.9 mm' (a point on the sphere)")
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
    "sphere_radius": ("sphere radius", "length", 0.0, 2.0, True, "mm"),
    "roller_radius": ("roller radius", "length", 0.0, 1.0, True, "mm"),
    "crown_radius": ("crown radius", "length", 0.0, 1.0, True, "mm"),
    "width": ("roller width", "length", 0.0, 1.0, True, "mm"),
    "preload": ("preload", "force", 0.0, 1e5, True, None),
    "mount_stiffness": ("mount stiffness", "stiffness", 0.0, 1e10, True, None),
    "youngs_modulus": ("Young's modulus", "pressure", 1e5, 1.2e12, False, "MPa"),
    "friction": ("friction coefficient", "dimensionless", 0.0, 3.0, True, None),
    "allowable_pressure": ("allowable pressure", "pressure", 1e4, 1e11, False, "MPa"),
    "creep": ("creep constant", "compliance", 0.0, 1.0, True, None),
    "creep_reference_force": ("creep reference force", "force", 0.0, 1e5, True, None),
    "direction_angle": ("direction angle", "angle", -2 * math.pi, 2 * math.pi, False, "deg"),
    "gamma": ("transmission angle γ", "angle", -math.pi, math.pi, False, "deg"),
    "load": ("load", "torque", -1e4, 1e4, False, None),
    "motor_speed": ("motor speed", "speed", 0.0, 1e4, True, None),
    "frame_distance": ("plate distance", "length", 0.0, 10.0, True, "mm"),
    "frame_thickness": ("plate thickness", "length", 0.0, 1.0, True, "mm"),
}
MAX_GRID_POINTS = 100_000      # per envelope axis (γ, load): a 1e-9° step would otherwise allocate terabytes
# effect parameters that must be above zero (zero would switch the effect off or be unphysical); every effect
# parameter must also lie within its `effects.Param` bounds (the fit's bounds)
POSITIVE_EFFECT_PARAMS = {("drive_longitudinal_creep", "scale"), ("steering_lateral_creep", "scale"),
                          ("drive_spin_creep", "scale"), ("rolling_resistance", "offset")}
_EFFECT_GUESS = {"length": "mm", "angle": "deg"}


def quantity(raw, key: str, where: str, names: dict | None = None, positive: str | None = None):
    """A dimensional field of PLAUSIBLE[key] in SI: finite (to_si), with `positive` ('a positive radius') the
    message for a value ≤ 0, then within the plausible range."""
    what, kind, lo, hi, lo_open, guess = PLAUSIBLE[key]
    value = to_si(raw, kind, where, names)
    if positive:
        _positive(value, where, positive)
    return check_range(value, raw, where, what, kind, lo, hi, lo_open=lo_open, guess=guess)


def effect_value(effect: str, param: str, raw, where: str, names: dict | None = None):
    """An effect parameter in SI, finite and within its physical range: the `effects.Param` bounds, the lower
    one exclusive for POSITIVE_EFFECT_PARAMS. Enforced: drive_longitudinal_creep.scale and
    steering_lateral_creep.scale in (0, 50], drive_spin_creep.scale in (0, 200], normal_force_variation.exponent
    in [0, 3], rolling_resistance.offset in (0, 5 mm], steering_offset.offset in [-0.2, 0.2] rad (±11.5°),
    drive_radius_mismatch.delta in [-0.2, 0.2], traction_saturation.mu_scale in [0.05, 5]."""
    spec = fx.EFFECTS[effect].params[param]
    value = to_si(raw, spec.kind, where, names)
    lo = spec.lower if math.isfinite(spec.lower) else None
    hi = spec.upper if math.isfinite(spec.upper) else None
    return check_range(value, raw, where, f"{effect}.{param}", spec.kind, lo, hi,
                       lo_open=(effect, param) in POSITIVE_EFFECT_PARAMS, guess=_EFFECT_GUESS.get(spec.kind))


def _grid(r: RangeSpec, kind, where):
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
    return np.linspace(a, b, int(round((b - a) / s)) + 1)


def resolve(spec: VariantSpec, where: str, overrides: dict | None = None) -> Layout:
    """Build the SI Layout. `overrides` maps parameter names to values (floats or CasADi symbols)."""
    names, overrides = {}, overrides or {}
    for k, v in spec.parameters.items():   # in order, so later parameters may use earlier ones
        names[k] = overrides[k] if k in overrides else _param(v, f"{where}: parameters.{k}", names)

    mats = {}
    for k, m in spec.materials.items():
        w = f"{where}: materials.{k}"
        mats[k] = Material(
            E=quantity(m.youngs_modulus, "youngs_modulus", f"{w}.youngs_modulus", names, "a positive value"),
            nu=to_si(m.poisson_ratio, "dimensionless", f"{w}.poisson_ratio", names),
            mu=quantity(m.friction, "friction", f"{w}.friction", names, "a positive value"),
            p_allow=None if m.allowable_pressure is None else quantity(
                m.allowable_pressure, "allowable_pressure", f"{w}.allowable_pressure", names, "a positive pressure"))
        if isinstance(mats[k].nu, float) and not 0 <= mats[k].nu < 0.5:
            raise InputError(f"{w}.poisson_ratio: expected 0 <= ν < 0.5, got {mats[k].nu:g}")

    def material(name, w):
        if name not in mats:
            raise InputError(f"{w}: unknown material '{name}'{suggest(name, mats)}")
        return mats[name]

    R = quantity(spec.sphere.radius, "sphere_radius", f"{where}: sphere.radius", names, "a positive radius")
    forks = {}
    for i, f in enumerate(spec.steering.forks):
        w = f"{where}: steering.forks[{i}]"
        axis = _vector(f.axis, f"{w}.axis", names)
        if not f.rollers:
            raise InputError(f"{w}.rollers: empty; every fork holds at least one roller (a steering roller's name)")
        for rn in f.rollers:
            if rn not in spec.rollers:
                raise InputError(f"{w}.rollers: unknown roller '{rn}'{suggest(rn, spec.rollers)}")
            if spec.rollers[rn].role != "steering":
                raise InputError(f"{w}.rollers: '{rn}' is a {spec.rollers[rn].role} roller; only steering rollers turn with φ")
            if rn in forks:
                raise InputError(f"{w}.rollers: '{rn}' is already on another fork")
            forks[rn] = (axis, f.sign)

    rollers = []
    defaults = spec.roller_defaults
    for rn, r in spec.rollers.items():
        w = f"{where}: rollers.{rn}"
        if r.role in ("drive", "follower") and r.shaft is None:
            raise InputError(f"{w}.shaft: missing (a {r.role} roller must name shaft 1 or 2)")
        if r.role == "steering" and r.shaft is not None:
            raise InputError(f"{w}.shaft: a steering roller is an idler and has no shaft")
        if r.role == "steering" and rn not in forks:
            raise InputError(f"{w}: steering roller is on no fork (steering.forks[].rollers)")
        radius = quantity(r.radius, "roller_radius", f"{w}.radius", names, "a positive radius")
        crown = radius if r.crown_radius is None else quantity(
            r.crown_radius, "crown_radius", f"{w}.crown_radius", names, "a positive radius")
        normal = _contact(r.contact, f"{w}.contact", names, R)
        axle = _vector(r.axle, f"{w}.axle", names)
        dot = ca.dot(ca.vec(ca.DM(normal) if isinstance(normal, np.ndarray) else normal),
                     ca.vec(ca.DM(axle) if isinstance(axle, np.ndarray) else axle))
        if isinstance(dot, (ca.DM, float)) and abs(float(dot)) > 1e-6:
            raise InputError(f"{w}.axle: not perpendicular to the contact normal (axle·normal = {float(dot):.4g}); "
                             "the axle must lie in the sphere's tangent plane at the contact")
        ratio = to_si(r.ratio, "dimensionless", f"{w}.ratio", names)
        if isinstance(ratio, float) and ratio == 0:
            raise InputError(f"{w}.ratio: expected a non-zero coupling ratio")
        if isinstance(ratio, float) and not 1e-3 <= abs(ratio) <= 1e3:
            raise InputError(f"{w}.ratio: {ratio:g} is not a plausible coupling ratio (expected 1e-3 <= |ratio| <= 1e3)")
        axis, sign = forks.get(rn, (None, 0))
        rollers.append(Roller(
            name=rn, role=r.role, shaft=r.shaft, ratio=ratio if r.role == "follower" else 1.0,
            normal=normal, axle=axle, radius=radius, crown_radius=crown,
            width=quantity(r.width, "width", f"{w}.width", names, "a positive value"),
            material=material(r.material, f"{w}.material"),
            preload=quantity(r.preload if r.preload is not None else defaults.preload, "preload",
                             f"{w}.preload" if r.preload is not None else f"{where}: roller_defaults.preload",
                             names, "a positive value"),
            stiffness=quantity(r.mount_stiffness if r.mount_stiffness is not None else defaults.mount_stiffness,
                               "mount_stiffness", f"{w}.mount_stiffness" if r.mount_stiffness is not None
                               else f"{where}: roller_defaults.mount_stiffness", names, "a positive value"),
            fork_axis=axis, fork_sign=sign))
    for s in (1, 2):
        if not any(r.role == "drive" and r.shaft == s for r in rollers):
            raise InputError(f"{where}: rollers: no drive roller on shaft {s} (role: drive, shaft: {s})")

    fx.check_effects(spec.effects, f"{where}: effects")
    eparams = {}
    for e, ps in spec.effect_parameters.items():
        if e not in fx.EFFECTS:
            raise InputError(f"{where}: effect_parameters.{e}: unknown effect{suggest(e, fx.EFFECTS)}")
        eparams[e] = {}
        for p, v in ps.items():
            known = fx.EFFECTS[e].params
            if p not in known:
                raise InputError(f"{where}: effect_parameters.{e}.{p}: unknown parameter{suggest(p, known)}")
            eparams[e][p] = effect_value(e, p, v, f"{where}: effect_parameters.{e}.{p}", names)
    if spec.frame is not None:     # drawn by `cvtdesign export` only, checked here with the rest
        _vector(spec.frame.side, f"{where}: frame.side", names)
        quantity(spec.frame.distance, "frame_distance", f"{where}: frame.distance", names, "a positive distance")
        quantity(spec.frame.thickness, "frame_thickness", f"{where}: frame.thickness", names, "a positive thickness")

    c = spec.contact
    env = spec.envelope
    return Layout(
        name=spec.name, file=where, sphere_radius=R, sphere_material=material(spec.sphere.material, f"{where}: sphere.material"),
        rollers=tuple(rollers),
        creep_drive=None if c.creep_drive is None else quantity(c.creep_drive, "creep", f"{where}: contact.creep_drive", names, "a positive value"),
        creep_steering=None if c.creep_steering is None else quantity(c.creep_steering, "creep", f"{where}: contact.creep_steering", names, "a positive value"),
        creep_reference_force=None if c.creep_reference_force is None else quantity(c.creep_reference_force, "creep_reference_force", f"{where}: contact.creep_reference_force", names, "a positive value"),
        effects=tuple(spec.effects), effect_parameters=eparams,
        gamma_grid=_grid(env.gamma, "angle", f"{where}: envelope.gamma"),
        load_grid=_grid(env.load, "torque", f"{where}: envelope.load"),
        motor_speed=quantity(env.motor_speed, "motor_speed", f"{where}: envelope.motor_speed", None, "a positive value"),
        parameters=names, spec=spec)


def _param(v, where, names):
    """A named parameter: any finite quantity with units (kept in SI), a plain number (SI) or an expression
    over earlier parameters."""
    from .units import MAX_QUANTITY_TEXT, parse_quantity, registry

    if isinstance(v, bool) or v is None:
        raise InputError(f"{where}: expected a number or a quantity like '60 mm', got {str(v).lower()}")
    if isinstance(v, (int, float)):
        return to_si(v, "dimensionless", where)
    text = str(v).strip()
    if text.startswith("="):
        return to_si(text, "dimensionless", where, names)
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


MAX_FILE_BYTES = 10 * 1024 * 1024   # a variant, study or protocol file is a few kB
MAX_NESTING = 50                     # YAML collections inside collections (a variant file needs 4)
MAX_NODES = 1_000_000                # YAML nodes after expanding aliases ("billion laughs")


class StrictLoader(yaml.SafeLoader):
    """PyYAML's SafeLoader, refusing a key repeated in one mapping (SafeLoader keeps the last silently) and
    collections nested deeper than MAX_NESTING (the composer recurses: 20,000 '[' exhaust Python's stack)."""

    def __init__(self, stream):
        super().__init__(stream)
        self._depth = 0

    def compose_node(self, parent, index):
        if self._depth >= MAX_NESTING:
            raise yaml.composer.ComposerError(None, None, f"collections nested more than {MAX_NESTING} deep",
                                              self.peek_event().start_mark)
        self._depth += 1
        try:
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            seen = {}
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=True)
                try:
                    first = seen.get(key)
                except TypeError:       # an unhashable key: SafeLoader's own error follows
                    continue
                if first is not None:
                    raise yaml.constructor.ConstructorError(
                        None, None, f"duplicate key '{shorten(key)}' (first on line {first + 1}); every key may "
                        "appear once in a mapping", key_node.start_mark)
                seen[key] = key_node.start_mark.line
        return super().construct_mapping(node, deep)


def _expanded_nodes(root) -> int:
    """Number of nodes of the document with every alias expanded (shared nodes counted at each use), stopping
    past MAX_NODES; a node that contains itself (a recursive alias) counts as too many."""
    size, state, stack = {}, {}, [root]
    while stack:
        node = stack[-1]
        children = [] if isinstance(node, yaml.ScalarNode) else \
            node.value if isinstance(node, yaml.SequenceNode) else [n for kv in node.value for n in kv]
        if state.get(id(node)) is None:
            state[id(node)] = "open"
            stack.extend(c for c in children if id(c) not in size)
            if any(state.get(id(c)) == "open" for c in children):
                return MAX_NODES + 1
            continue
        stack.pop()
        if id(node) not in size:
            size[id(node)] = min(1 + sum(size[id(c)] for c in children), MAX_NODES + 1)
            state[id(node)] = "done"
    return size[id(root)]


def load_yaml(path):
    """The YAML document of a file, read with the limits above; every failure is one InputError line."""
    where = str(path)
    try:
        with open(path, "rb") as f:
            raw = f.read(MAX_FILE_BYTES + 1)
    except OSError as e:
        raise InputError(f"{where}: cannot read file ({e.strerror or type(e).__name__})") from None
    if len(raw) > MAX_FILE_BYTES:
        raise InputError(f"{where}: larger than {MAX_FILE_BYTES // 2**20} MB; expected a YAML file of a few kB")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        line = raw[:e.start].count(b"\n") + 1
        raise InputError(f"{where}: line {line}: not UTF-8 text (byte 0x{raw[e.start]:02x}); expected a YAML "
                         "file saved as UTF-8") from None
    loader = None
    try:
        loader = StrictLoader(text)      # its reader refuses control characters (a NUL byte) here already
        node = loader.get_single_node()
        if node is not None and _expanded_nodes(node) > MAX_NODES:
            raise InputError(f"{where}: its aliases expand to more than {MAX_NODES} YAML nodes (or refer to "
                             "themselves); expected a plain YAML file")
        return None if node is None else loader.construct_document(node)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        line = f" (line {mark.line + 1})" if mark else ""
        problem = getattr(e, "problem", None) or getattr(e, "reason", None) or str(e)
        raise InputError(f"{where}: not valid YAML{line}: {' '.join(str(problem).split())}") from None
    except (ValueError, OverflowError, RecursionError) as e:   # e.g. an integer beyond Python's 4300 digits
        raise InputError(f"{where}: not valid YAML: {' '.join(str(e).split()) or type(e).__name__}") from None
    finally:
        if loader is not None:
            loader.dispose()


def read_spec(path, model: type[BaseModel], fields: str):
    """Read a YAML file (`load_yaml`) and validate it against `model`; every failure is one InputError line."""
    where = str(path)
    data = load_yaml(path)
    if not isinstance(data, dict):
        raise InputError(f"{where}: expected a YAML mapping with fields {fields}")
    try:
        return model.model_validate(data)
    except ValidationError as err:
        raise _schema_error(err, where, model) from None


def load_spec(path) -> VariantSpec:
    return read_spec(path, VariantSpec, "name, materials, sphere, rollers, steering")


def load_variant(path, overrides: dict | None = None, check: bool = True) -> Layout:
    """Read, validate and resolve a variant file; with `check`, run the geometric checks too."""
    layout = resolve(load_spec(path), str(path), overrides)
    if check:
        from .checks import check_layout
        check_layout(layout)
    return layout
