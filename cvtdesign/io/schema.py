"""The schema of variant files (pydantic): every field, its type and default.

Values are read into SI and checked by io.variant; the YAML itself by io.yaml_file.
"""
from __future__ import annotations

import re
from typing import Annotated, Literal, Union

from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, ValidationError
from pydantic_core import PydanticCustomError

from cvtdesign.errors import InputError, shorten, suggest


def no_bool(v):
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
Num = Annotated[Union[float, int, str], BeforeValidator(no_bool)]   # a plain number (SI), a quantity or '= expr'
Coord = Annotated[float, BeforeValidator(no_bool)]                   # a component of a direction
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
    shaft: Annotated[Literal[1, 2] | None, BeforeValidator(no_bool)] = None
    ratio: Num = 1.0
    radius: Num | None = None
    material: str | None = None
    crown_radius: Num | None = None
    width: Num | None = None
    preload: Num | None = None
    mount_stiffness: Num | None = None


class RollerDefaults(Strict):
    """Values for every roller that does not give its own (a roller's own field overrides these)."""
    radius: Num | None = None
    material: str | None = None
    crown_radius: Num | None = None
    width: Num = "24 mm"
    preload: Num = "100 N"
    mount_stiffness: Num = "2e5 N/m"


class ForkSpec(Strict):
    rollers: list[str]
    axis: Union[str, list[Coord], Spherical]
    sign: Annotated[Literal[1, -1], BeforeValidator(no_bool)] = 1


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


def schema_error(err: ValidationError, where: str, root=None) -> InputError:
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
