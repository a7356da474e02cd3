"""The schema of variant files (pydantic): every field, its type and default.

Values are read into SI and checked by io.variant; the YAML itself by io.yaml_file.
"""
from __future__ import annotations

import re
from typing import Annotated, Literal, Union

from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, Field, ValidationError
from pydantic_core import PydanticCustomError, PydanticUndefined

from cvtdesign.core.contact.laws import DEFAULT, LAWS
from cvtdesign.core.effects import CALIBRATION, KIM_MODEL
from cvtdesign.errors import InputError, shorten, suggest
from cvtdesign.io.units import KINDS


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


def law_name(v):
    """A contact law's name: one of core.contact.laws.LAWS (read when the file is, so a law added there is known)."""
    if v not in LAWS:
        raise PydanticCustomError("law_name", "input should be {laws}, got '{value}'",
                                  {"laws": " or ".join(f"'{k}'" for k in LAWS), "value": shorten(v)})
    return v


LawName = Annotated[str, AfterValidator(law_name)]
Num = Annotated[Union[float, int, str], BeforeValidator(no_bool)]   # a plain number (SI), a quantity or '= expr'


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


def unit_text(kind: str) -> str:
    """How a value of a units.KINDS kind is written: 'length: a plain number is m, or a quantity like '40 mm''."""
    si, example = KINDS[kind]
    if kind == "dimensionless":
        return "a plain number (no unit)"
    return f"{kind} [{si}]: a plain number is {si}, or a quantity like {example}"


def spec_field(meaning: str, default=PydanticUndefined, *, kind: str | None = None, plausible: str | None = None):
    """A schema field whose description is its meaning followed by its unit (`kind`, a units.KINDS key).
    The description is the one text of docs/variant-reference.md and of the comments `cvtdesign new` writes.
    `kind` and `plausible` (the io.variant.PLAUSIBLE key of the range a value must lie in) are kept in the
    field's json_schema_extra for the reference."""
    description = meaning if kind is None else f"{meaning}; {unit_text(kind)}"
    extra = {k: v for k, v in (("kind", kind), ("plausible", plausible)) if v}
    return Field(default, description=description, json_schema_extra=extra or None)


MAX_COUNT = 10_000   # starts, iterations, Pareto points, replicates: more is a typo (1e9 starts filled memory in seconds)

DIRECTION = ("a frame vector name (x, y, z, d1, d2, d3, c1, c2, c3, optionally with '-': '-d1'), a list of three "
             "numbers or '= expressions' (normalised: [1, '= sqrt(3)', 0]) or {polar, azimuth}")


class Spherical(Strict):
    """A direction from the sphere centre by its two angles."""
    polar: Num = spec_field("angle θ from +z (0: +z, 90 deg: the xy plane, 180 deg: −z)", kind="angle",
                            plausible="direction_angle")
    azimuth: Num = spec_field("angle from +x towards +y about z", kind="angle", plausible="direction_angle")


class Aged(Strict):
    """One ageing constant of a material: its value, its uncertainty and where it comes from."""
    value: Num = spec_field("the value, in the constant's unit")
    std: Num = spec_field("its standard deviation (1σ): relative ('30 %') or in the constant's unit")
    source: str = spec_field("where the value comes from (a measurement, a handbook, an assumption)")


AGEING = {   # constant → (kind, meaning); `cvtdesign life` (docs/life.md)
    "loss_fraction": ("dimensionless", "hysteresis loss fraction α: the share of the elastic work of rolling "
                                       "lost as heat (Johnson, Contact Mechanics, ch. 9)"),
    "density": ("density", "density ρ"),
    "specific_heat": ("specific_heat", "specific heat c"),
    "conductivity": ("conductivity", "thermal conductivity k"),
    "max_temperature": ("temperature", "the highest temperature in continuous use (urethane: its bond to the "
                                       "hub)"),
    "hot_temperature": ("temperature", "the temperature at which the two factors below are given (25 °C is "
                                       "1)"),
    "modulus_factor": ("dimensionless", "Young's modulus at hot_temperature over its value at 25 °C"),
    "friction_factor": ("dimensionless", "μ at hot_temperature over its value at 25 °C"),
    "wear_coefficient": ("wear_coefficient", "volume worn per frictional energy (Archard/Grosch, energy form)"),
    "fatigue_pressure": ("pressure", "steels: the Hertz peak pressure of a rolling-contact fatigue test"),
    "fatigue_cycles": ("dimensionless", "steels: the L10 life in stress cycles at fatigue_pressure"),
    "fatigue_exponent": ("dimensionless", "steels: the stress-life exponent n, L10 ∝ p_max^-n "
                                          "(Lundberg–Palmgren, point contact: 9)"),
    "fatigue_rolling": ("length", "steels: the fatigue test contact's patch semi-axis along rolling; with "
                                  "fatigue_across and fatigue_track, Lundberg–Palmgren's stressed volume "
                                  "(without them a contact is taken at the test's size and shape)"),
    "fatigue_across": ("length", "steels: the fatigue test contact's patch semi-axis across rolling"),
    "fatigue_track": ("length", "steels: the length of the fatigue test contact's running track"),
}
AgeingSpec = type("AgeingSpec", (Strict,), {
    "__doc__": "How a material heats, wears and tires (`cvtdesign life`, docs/life.md); every constant optional.",
    "__annotations__": {k: Aged | None for k in AGEING},
    **{k: spec_field(f"{meaning}; {{value, std, source}}; value: {unit_text(kind)}", None)
       for k, (kind, meaning) in AGEING.items()}})


class MaterialSpec(Strict):
    """A material the sphere or a roller is made of (Hertz contact, friction, allowable pressure)."""
    youngs_modulus: Num = spec_field("Young's modulus E (urethane 82A ≈ 10.7 MPa)", kind="pressure",
                                     plausible="youngs_modulus")
    poisson_ratio: Num = spec_field("Poisson's ratio ν, 0 ≤ ν < 0.5 (urethane ≈ 0.48)", kind="dimensionless")
    friction: Num | None = spec_field("not a material's: friction belongs to a pair of materials (`pairs`); "
                                      "refused here, with where to write it", None, kind="dimensionless")
    allowable_pressure: Num | None = spec_field(
        "allowable Hertz peak pressure, a constraint of `cvtdesign optimise` (omitted: not checked)", None,
        kind="pressure", plausible="allowable_pressure")
    youngs_modulus_std: Num | None = spec_field(
        "relative 1σ of youngs_modulus, e.g. '25 %' (omitted: 25 %, the spread of a modulus read from a Shore A "
        "hardness; an interval says it was assumed)", None, kind="dimensionless")
    family: str | None = spec_field(
        "the class of material ('polyurethane'): a material with no calibration of its own takes its family's "
        "(transferred, with a wider interval; docs/materials.md)", None)
    description: str = spec_field("what the material is (free text)", "")
    ageing: AgeingSpec | None = spec_field(
        "how it heats, wears and tires (`cvtdesign life`); omitted, or a constant omitted: the library's "
        "material of the same name gives it", None)


class PairSpec(Strict):
    """The friction of one pair of materials: friction belongs to the pair, not to either material."""
    materials: list[str] = spec_field("the two materials by name, in any order: [roller's, sphere's]")
    friction: Num = spec_field("nominal friction coefficient μ of the pair, dry", kind="dimensionless",
                               plausible="friction")
    range: list[Num] = spec_field("the range μ is known to within, [low, high] (an interval takes it as a "
                                  "uniform spread)", kind="dimensionless")
    source: str = spec_field("where μ and its range come from (free text)")


class SphereSpec(Strict):
    """The sphere; its centre is the origin of the frame x, y, z."""
    radius: Num = spec_field("sphere radius R", kind="length", plausible="sphere_radius")
    material: str = spec_field("the sphere's material: a name under `materials`")


class RollerSpec(Strict):
    """One roller. `contact` is where it touches the sphere, given as a direction from the sphere centre
    (a frame name such as 'd2' or '-c1', a list of three plain numbers, normalised, or {polar, azimuth}) or
    as a point: a list of three lengths (e.g. ["0 mm", "0 mm", "63.5 mm"] or "= expressions" over the
    parameters, in m), which must lie on the sphere (|p| = sphere radius within 1e-6 relative). Plain
    numbers are always a direction, never a point; a list mixing plain numbers and lengths is refused.
    `axle` is the positive spin axis, perpendicular to the contact normal."""
    role: Literal["drive", "follower", "steering"] = spec_field(
        "drive: turns with its shaft (each of shafts 1 and 2 needs one); follower: coupled to a shaft at "
        "`ratio` times its speed; steering: an idler on a fork (steering.forks) that sets the sphere's axis")
    contact: Union[str, list[Num], Spherical] = spec_field(
        f"where the roller touches the sphere, at φ = 0: the outward contact normal n as {DIRECTION}; or the "
        "contact point as a list of three lengths ('44.9 mm'; with one such, '= expr' in m for the others), "
        "which must lie on the sphere")
    axle: Union[str, list[Num], Spherical] = spec_field(
        f"the roller's positive spin axis a at φ = 0, perpendicular to the contact normal, as {DIRECTION}; "
        "it rolls along n × a, and its shaft's speed and torque count positive about it")
    shaft: Annotated[Literal[1, 2] | None, BeforeValidator(no_bool)] = spec_field(
        "the shaft (1: motor, 2: brake) a drive or follower roller is on; a steering roller has none", None)
    ratio: Num = spec_field("a follower's speed / its shaft's speed (negative: turns the other way), "
                            "1e-3 ≤ |ratio| ≤ 1e3; ignored for drive and steering rollers", 1.0,
                            kind="dimensionless")
    radius: Num | None = spec_field("rolling radius r (omitted: roller_defaults.radius)", None, kind="length",
                                    plausible="roller_radius")
    material: str | None = spec_field("the roller's material, a name under `materials` (omitted: "
                                      "roller_defaults.material)", None)
    crown_radius: Num | None = spec_field("crown radius of the tread across the roller (omitted: "
                                          "roller_defaults.crown_radius, else the rolling radius)", None,
                                          kind="length", plausible="crown_radius")
    width: Num | None = spec_field("tread width along the axle, for the overlap check and the CAD export "
                                   "(omitted: roller_defaults.width)", None, kind="length", plausible="width")
    preload: Num | None = spec_field("normal force on the sphere with the sphere centred (omitted: "
                                     "roller_defaults.preload)", None, kind="force", plausible="preload")
    mount_stiffness: Num | None = spec_field("normal stiffness of the roller's mount and contact: N = preload + "
                                             "k·n·δ for a sphere displacement δ (omitted: "
                                             "roller_defaults.mount_stiffness)", None, kind="stiffness",
                                             plausible="mount_stiffness")


class RollerDefaults(Strict):
    """Values for every roller that does not give its own (a roller's own field overrides these)."""
    radius: Num | None = spec_field("rolling radius of every roller that gives none (no default: each roller "
                                    "then needs its own)", None, kind="length", plausible="roller_radius")
    material: str | None = spec_field("material of every roller that gives none, a name under `materials`", None)
    crown_radius: Num | None = spec_field("crown radius of every roller that gives none (omitted here and on "
                                          "the roller: its rolling radius)", None, kind="length",
                                          plausible="crown_radius")
    width: Num = spec_field("tread width of every roller that gives none", "24 mm", kind="length",
                            plausible="width")
    preload: Num = spec_field("normal preload of every roller that gives none", "100 N", kind="force",
                              plausible="preload")
    mount_stiffness: Num = spec_field("mount stiffness of every roller that gives none", "2e5 N/m",
                                      kind="stiffness", plausible="mount_stiffness")


class ForkSpec(Strict):
    """A steering fork: turns its rollers' contact normals and axles about `axis` by ratio·φ, φ being the
    linkage's one steering angle. Which forks and ratios steer together: docs/linkages.md."""
    rollers: list[str] = spec_field("names of the steering rollers this fork carries (at least one; each "
                                    "steering roller on exactly one fork)")
    axis: Union[str, list[Num], Spherical] = spec_field(
        f"the fork's turning axis through the sphere centre, as {DIRECTION}")
    ratio: Num | None = spec_field(
        "the fork's gear ratio in the linkage: it turns by ratio·φ about `axis` (right-handed); negative: the "
        "other way; 0.01 ≤ |ratio| ≤ 100, a plain number or '= expression' (omitted: `sign`, else 1). The "
        "rollers of all forks must turn the sphere's axis alike (docs/linkages.md): in practice one |ratio| "
        "for the whole linkage", None, kind="dimensionless")
    sign: Annotated[Literal[1, -1] | None, BeforeValidator(no_bool)] = spec_field(
        "the same as `ratio: 1` or `ratio: -1` (-1: forks geared in opposite senses, as Kim's CVT); give "
        "`ratio` or `sign`, not both", None)


class SteeringSpec(Strict):
    """The steering linkage: forks that all turn with one steering angle φ (each by its ratio·φ)."""
    forks: list[ForkSpec] = spec_field("the forks; each fork's fields: rollers, axis, ratio (or sign)")


class CalibrationSpec(Strict):
    """Factors on the theory's compliances, for a contact law without fitted creep constants (1: the theory as
    it stands). A factor given here replaces the materials library's calibration of those contacts; an omitted
    one leaves it."""
    drive: Num | None = spec_field("factor on the compliances of the drive and follower contacts (fitted by "
                                   f"diagnose as {CALIBRATION['drive']}.scale; omitted: the library's calibration, "
                                   "else the theory)", None, kind="dimensionless", plausible="calibration")
    steering: Num | None = spec_field("factor on the compliances of the steering contacts (fitted by diagnose as "
                                      f"{CALIBRATION['steering']}.scale; omitted: as for drive)", None,
                                      kind="dimensionless", plausible="calibration")


class UncertaintySpec(Strict):
    """The relative standard deviation (1σ) of the creep compliance that the variant's own constants give
    (creep_drive, creep_steering or calibration factors); a library calibration carries its own."""
    drive: Num | None = spec_field("of the drive and follower contacts, e.g. '1.3 %'", None, kind="dimensionless")
    steering: Num | None = spec_field("of the steering contacts", None, kind="dimensionless")


class FittedOnSpec(Strict):
    """The pair of materials each fitted creep constant was fitted for: a constant belongs to its pair."""
    drive: list[str] | None = spec_field("creep_drive's [roller material, sphere material]", None)
    steering: list[str] | None = spec_field("creep_steering's [roller material, sphere material]", None)


class ContactSpec(Strict):
    """The contact law and its constants. A law with fitted creep constants takes creep_drive, creep_steering
    and creep_reference_force; a law on a theory takes `calibration` factors on the theory's compliances, or
    the materials library's calibration. The laws are listed below this table (core.contact.laws)."""
    law: LawName = spec_field("the contact law (the laws: below this table)", DEFAULT)
    calibration: CalibrationSpec = spec_field("factors on the theory's compliances (laws without fitted creep "
                                              "constants): drive, steering", CalibrationSpec())
    creep_drive: Num | None = spec_field("creep constant ε_D of drive and follower rollers: slip ratio per "
                                         "newton of tangential force (omitted: Hertz + Kalker C11)", None,
                                         kind="compliance", plausible="creep")
    creep_steering: Num | None = spec_field("creep constant ε_S of steering rollers: slip angle [rad] per newton "
                                            "of lateral force (omitted: Hertz + Kalker C22)", None,
                                            kind="compliance", plausible="creep")
    creep_reference_force: Num | None = spec_field(
        "normal force at which creep_drive and creep_steering hold (omitted: each roller's preload)", None,
        kind="force", plausible="creep_reference_force")
    uncertainty: UncertaintySpec = spec_field(
        "relative 1σ of the compliance the constants above give: drive, steering (omitted: none stated; a "
        "library calibration carries its own)", UncertaintySpec())
    fitted_on: FittedOnSpec = spec_field(
        "the materials creep_drive and creep_steering were fitted for, each [roller, sphere]; needed with them: a "
        "roller of other materials is refused (the constants belong to their pair)", FittedOnSpec())


class RangeSpec(Strict):
    """An axis of operating points: start, start + step, ..., stop."""
    start: Num = spec_field("first value, in the axis's unit (γ: angle, load: torque)")
    stop: Num = spec_field("last value (at least start), in the axis's unit")
    step: Num = spec_field("spacing of the values (above 0), in the axis's unit")


class EnvelopeSpec(Strict):
    """The operating envelope `compare` and `optimise` evaluate: every γ with every load, motor at motor_speed."""
    gamma: RangeSpec = spec_field("commanded transmission angle γ (docs/conventions.md), each of start, stop, "
                                  "step", RangeSpec(start="-80 deg", stop="80 deg", step="10 deg"), kind="angle",
                                  plausible="gamma")
    load: RangeSpec = spec_field("lateral load τ⊥ (for Kim's layout −τ1 sin γ + τ2 cos γ), each of start, "
                                 "stop, step", RangeSpec(start="-1 N*m", stop="1 N*m", step="0.1 N*m"),
                                 kind="torque", plausible="load")
    motor_speed: Num = spec_field("speed ω1 of shaft 1 (the motor), forwards about its drive roller's axle",
                                  "10 rad/s", kind="speed", plausible="motor_speed")


class FrameSpec(Strict):
    """A mounting plate, drawn by `cvtdesign export` only: perpendicular to `side` (a vector from the sphere
    centre), its near face `distance` from the centre, sized to the assembly's outline."""
    side: Union[str, list[Num], Spherical] = spec_field(f"the side of the sphere the plate is on, as {DIRECTION}")
    distance: Num = spec_field("distance from the sphere centre to the plate's near face", kind="length",
                               plausible="frame_distance")
    thickness: Num = spec_field("plate thickness", "10 mm", kind="length", plausible="frame_thickness")


class DynamicsSpec(Strict):
    """The inertias and the steering motor of `cvtdesign transient` (docs/dynamics.md); each left out gets its
    default, which the command reports as assumed."""
    sphere_inertia: Num | None = spec_field(
        "the sphere's moment of inertia (omitted: a uniform solid sphere of its material's density)", None,
        kind="inertia")
    roller_inertia: Num | None = spec_field(
        "every roller's moment of inertia about its axle (omitted: a solid disc of its material's density, radius "
        "and width)", None, kind="inertia")
    output_inertia: Num | None = spec_field(
        "shaft 2's moment of inertia with its rollers and the load it drives (omitted: its rollers only)", None,
        kind="inertia")
    steering_inertia: Num | None = spec_field(
        "the steering's moment of inertia at the steering angle: forks, their rollers and the motor's rotor "
        "(omitted: the rollers as point masses, a fork frame as heavy, and motor_inertia)", None, kind="inertia")
    motor_torque: Num | None = spec_field(
        "the steering motor's largest torque at the steering angle (omitted: 4 N·m, assumed)", None, kind="torque")
    motor_speed: Num | None = spec_field(
        "the steering motor's no-load speed at the steering angle (omitted: 60 rpm, assumed)", None, kind="speed")
    motor_inertia: Num | None = spec_field(
        "the motor's rotor inertia reflected to the steering angle (omitted: 1e-3 kg·m², assumed)", None,
        kind="inertia")
    servo_bandwidth: Num | None = spec_field(
        "the steering position servo's bandwidth on the steering inertia alone (omitted: 20 Hz, assumed)", None,
        kind="frequency")
    relaxation_factor: Num | None = spec_field(
        "each contact's relaxation length over its patch's semi-axis along the rolling direction (omitted: 1)",
        None, kind="dimensionless")


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
    |θ| ≤ 360°; envelope γ within ±180° (relabelled shafts put Kim's γ at 10°..170°), load |τ| ≤ 1e4 N·m
    and at most what the variant's contacts can carry (`load_capacity`: 2 × Σ μ·P·max(R, r), 40.6 N·m for
    Kim's CVT), at most MAX_GRID_POINTS points per axis and MAX_POINTS (γ × load) in all, fewer where half the
    machine's free memory holds fewer, motor speed 0 < ω ≤ 1e4 rad/s; frame distance 0 < d ≤ 10 m,
    thickness 0 < t ≤ 1 m;
    effect parameters within their `effects.Param` bounds, the lower one exclusive for a `positive` one. Every
    value must be finite; named `parameters` are any finite quantity (their use is checked where they land).
    A quantity must be of its field's kind, the angle counted as a kind of its own (io.units.dimension): an
    angle field takes angle units or a plain number (rad), never '%' or a ratio such as 'm/m'; a plain-number
    field takes no angle unit; a speed is an angle per time (rad/s, rpm), never 'Hz' or '1/s'."""
    name: Name = spec_field("the variant's name: letters, digits, '_', '.', '+', '-', not starting with '.', at "
                            "most 100 characters (it becomes part of file names: <name>.step, <name>_layout.png)")
    description: str = spec_field("one line saying what the variant is (free text)", "")
    parameters: dict[str, Num] = spec_field(
        "named values that other fields use in '= expr' and that optimisation studies may vary: name → a "
        "quantity ('63.5 mm'), a plain number (SI) or '= expr' over the parameters above it; held in SI", {})
    materials: dict[str, MaterialSpec] = spec_field(
        "the variant's own materials by name; each: youngs_modulus, poisson_ratio, friction, allowable_pressure, "
        "description. A material it names but does not define comes from the materials library "
        "(docs/materials.md)", {})
    pairs: list[PairSpec] = spec_field(
        "the friction of pairs of materials: each materials [roller's, sphere's], friction, range, source; they "
        "take precedence over the materials library's pairs", [])
    calibration_machine: bool = spec_field(
        "true for the machine the materials' calibration was measured on (Kim et al.'s CVT): its preload is the one "
        "the calibration assumed, so the calibration absorbs that assumption; any other layout's preload is its own",
        False)
    preload_std: Num | None = spec_field(
        "relative 1σ of every roller's preload as built, e.g. '5 %' (omitted: 20 %, assumed: no paper states "
        "Kim et al.'s preload; an interval says it was assumed)", None, kind="dimensionless")
    dynamics: DynamicsSpec = spec_field(
        "the inertias and the steering motor of the dynamic model (`cvtdesign transient`, docs/dynamics.md); "
        "each omitted gets a default that the command reports as assumed", DynamicsSpec())
    material_library: list[str] = spec_field(
        "files of the user's own materials and calibrations (the library's format), relative to this file; "
        "they add to the shipped library and take precedence over it", [])
    sphere: SphereSpec = spec_field("the sphere: radius, material")
    roller_defaults: RollerDefaults = spec_field(
        "values for every roller that omits them: radius, material, crown_radius, width, preload, "
        "mount_stiffness", RollerDefaults())
    rollers: dict[str, RollerSpec] = spec_field(
        "the rollers by name; each: role, contact, axle, shaft, ratio, radius, material, crown_radius, width, "
        "preload, mount_stiffness; shafts 1 and 2 each need a drive roller")
    steering: SteeringSpec = spec_field("the steering linkage: its forks")
    contact: ContactSpec = spec_field("the contact law and its constants: law, calibration (laws on a theory), "
                                      "creep_drive, creep_steering, creep_reference_force (laws with fitted "
                                      "constants)", ContactSpec())
    effects: list[str] = spec_field("the effects the model includes, names from the effect vocabulary "
                                    "(docs/effects.md); [] is the ideal CVT",
                                    list(KIM_MODEL))
    effect_parameters: dict[str, dict[str, Num]] = spec_field(
        "effect parameters that differ from their defaults: effect → {parameter: value}, each in the "
        "parameter's unit (docs/effects.md)", {})
    effect_uncertainty: dict[str, dict[str, Num]] = spec_field(
        "the standard deviation (1σ) of effect parameters fitted to measurements (`cvtdesign diagnose` reports "
        "them): effect → {parameter: σ}, in the parameter's unit; `compare` carries them into every figure's "
        "interval", {})
    envelope: EnvelopeSpec = spec_field("the operating points `compare` and `optimise` evaluate: gamma, load, "
                                        "motor_speed", EnvelopeSpec())
    frame: FrameSpec | None = spec_field("a mounting plate drawn by `cvtdesign export`: side, distance, "
                                         "thickness (omitted: no plate)", None)


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
    if e["type"] == "literal_error" and isinstance(e.get("input"), str):    # the value given, and the nearest
        options = re.findall(r"'([^']*)'", e["ctx"]["expected"])
        return InputError(f"{where}: {path}: input should be {e['ctx']['expected']}, got '{shorten(e['input'])}'"
                          f"{suggest(e['input'], options)}")
    return InputError(f"{where}: {path}: {e['msg'].lower()}")
