"""Variant files (YAML) → a validated, SI-valued `Layout` that the model compiler reads.

The schema (pydantic) fixes the fields; `load_variant` turns every problem into one `InputError` line
naming the file and the field. Geometric checks (axle ⊥ normal, contact points on the sphere, preloads that
balance, overlapping rollers, steering that cannot fix an axis, couplings that fight) run on the resolved layout.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Literal, Union

import casadi as ca
import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, ValidationError

from . import effects as fx
from .geometry import named_vector, spherical
from .units import InputError, suggest, to_si

Num = Union[float, int, str]
VectorSpec = Union[str, list[float], "Spherical"]


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
    axle: Union[str, list[float], Spherical]
    radius: Num
    material: str
    crown_radius: Num | None = None
    width: Num = "24 mm"
    shaft: Literal[1, 2] | None = None
    ratio: Num = 1.0
    preload: Num | None = None
    mount_stiffness: Num | None = None


class RollerDefaults(Strict):
    preload: Num = "100 N"
    mount_stiffness: Num = "2e5 N/m"


class ForkSpec(Strict):
    rollers: list[str]
    axis: Union[str, list[float], Spherical]
    sign: Literal[1, -1] = 1


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
    side: Union[str, list[float], Spherical]
    distance: Num
    thickness: Num = "10 mm"


class VariantSpec(Strict):
    name: str
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
    loc = [p for p in loc if not (p in ("str", "float", "int", "Spherical") or p.startswith(("list[", "literal[")))]
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
        return spherical(to_si(spec.polar, "angle", f"{where}.polar", names),
                         to_si(spec.azimuth, "angle", f"{where}.azimuth", names))
    v = np.asarray(spec, dtype=float)
    if v.shape != (3,) or np.linalg.norm(v) == 0:
        raise InputError(f"{where}: expected a non-zero vector of 3 numbers, got {spec}")
    return v / np.linalg.norm(v)


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


def _grid(r: RangeSpec, kind, where):
    a, b, s = (to_si(getattr(r, k), kind, f"{where}.{k}") for k in ("start", "stop", "step"))
    if not s > 0 or b < a:
        raise InputError(f"{where}: expected start <= stop and step > 0")
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
            E=_positive(to_si(m.youngs_modulus, "pressure", f"{w}.youngs_modulus", names), f"{w}.youngs_modulus"),
            nu=to_si(m.poisson_ratio, "dimensionless", f"{w}.poisson_ratio", names),
            mu=_positive(to_si(m.friction, "dimensionless", f"{w}.friction", names), f"{w}.friction"),
            p_allow=None if m.allowable_pressure is None else to_si(m.allowable_pressure, "pressure", f"{w}.allowable_pressure", names))
        if isinstance(mats[k].nu, float) and not 0 <= mats[k].nu < 0.5:
            raise InputError(f"{w}.poisson_ratio: expected 0 <= ν < 0.5, got {mats[k].nu:g}")

    def material(name, w):
        if name not in mats:
            raise InputError(f"{w}: unknown material '{name}'{suggest(name, mats)}")
        return mats[name]

    R = _positive(to_si(spec.sphere.radius, "length", f"{where}: sphere.radius", names), f"{where}: sphere.radius")
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
        radius = _positive(to_si(r.radius, "length", f"{w}.radius", names), f"{w}.radius", "a positive radius")
        crown = radius if r.crown_radius is None else _positive(
            to_si(r.crown_radius, "length", f"{w}.crown_radius", names), f"{w}.crown_radius", "a positive radius")
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
        axis, sign = forks.get(rn, (None, 0))
        rollers.append(Roller(
            name=rn, role=r.role, shaft=r.shaft, ratio=ratio if r.role == "follower" else 1.0,
            normal=normal, axle=axle, radius=radius, crown_radius=crown,
            width=_positive(to_si(r.width, "length", f"{w}.width", names), f"{w}.width"),
            material=material(r.material, f"{w}.material"),
            preload=_positive(to_si(r.preload if r.preload is not None else defaults.preload, "force", f"{w}.preload", names), f"{w}.preload"),
            stiffness=_positive(to_si(r.mount_stiffness if r.mount_stiffness is not None else defaults.mount_stiffness,
                                      "stiffness", f"{w}.mount_stiffness", names), f"{w}.mount_stiffness"),
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
            eparams[e][p] = to_si(v, known[p].kind, f"{where}: effect_parameters.{e}.{p}", names)

    c = spec.contact
    env = spec.envelope
    return Layout(
        name=spec.name, file=where, sphere_radius=R, sphere_material=material(spec.sphere.material, f"{where}: sphere.material"),
        rollers=tuple(rollers),
        creep_drive=None if c.creep_drive is None else _positive(to_si(c.creep_drive, "compliance", f"{where}: contact.creep_drive", names), f"{where}: contact.creep_drive"),
        creep_steering=None if c.creep_steering is None else _positive(to_si(c.creep_steering, "compliance", f"{where}: contact.creep_steering", names), f"{where}: contact.creep_steering"),
        creep_reference_force=None if c.creep_reference_force is None else _positive(to_si(c.creep_reference_force, "force", f"{where}: contact.creep_reference_force", names), f"{where}: contact.creep_reference_force"),
        effects=tuple(spec.effects), effect_parameters=eparams,
        gamma_grid=_grid(env.gamma, "angle", f"{where}: envelope.gamma"),
        load_grid=_grid(env.load, "torque", f"{where}: envelope.load"),
        motor_speed=_positive(to_si(env.motor_speed, "speed", f"{where}: envelope.motor_speed"), f"{where}: envelope.motor_speed"),
        parameters=names, spec=spec)


def _param(v, where, names):
    """A named parameter: any quantity with units (kept in SI) or an expression over earlier parameters."""
    if isinstance(v, (int, float)):
        return float(v)
    text = str(v).strip()
    if text.startswith("="):
        return to_si(text, "dimensionless", where, names)
    from .units import registry
    import pint
    try:
        return float(registry().Quantity(text).to_base_units().magnitude)
    except (pint.errors.UndefinedUnitError, ValueError, TypeError, AttributeError, AssertionError):
        raise InputError(f"{where}: expected a number or a quantity like '60 mm', got '{v}'") from None


def read_spec(path, model: type[BaseModel], fields: str):
    """Read a YAML file and validate it against `model`; every failure is one InputError line."""
    where = str(path)
    try:
        text = Path(path).read_text()
    except OSError as e:
        raise InputError(f"{where}: cannot read file ({e.strerror})") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        line = f" (line {mark.line + 1})" if mark else ""
        raise InputError(f"{where}: not valid YAML{line}: {getattr(e, 'problem', e)}") from None
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
