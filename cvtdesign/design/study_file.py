"""The study file: what a design optimisation asks for, read and checked.

A study file names a base variant, the variant parameters that are free (with bounds), an objective and
constraints (StudySpec). `load_study` reads it; `problem_inputs` checks, for one variant file and sweep
point, everything the NLP is built from (parameters, bounds, geometry, and by `check_settings` the effects,
envelope, constraint values, duty cycle and solver options), without compiling anything.

Objectives (design.objectives): `worst_alpha` (max |α| over the envelope), `rms_alpha`, `power_loss`
(weighted mean power loss over a duty cycle of (γ, τ⊥) points [W]), `pareto` (the slip/loss front; its
knee is the optimum).
Constraints: Hertz peak pressure ≤ the material's allowable, traction |F| ≤ (1 − margin)·μN (no gross
slip), normal force N ≥ N_min at every contact (the rollers stay in contact), roller–roller clearance, an
assembly envelope radius, and the steering linkage still reaching every γ of the envelope.

`constraints.min_normal_force` is a force ('5 N'); left out (null) it is 5 % of each roller's base preload
(`min_normal_force`). It cannot be switched off: a design with a contact at N ≤ 0 is outside the model,
whatever else the study asks for (a smaller positive floor is allowed).

A variant file as a study uses it (`StudyVariant`: its text, its contents with the study's calibration merged
in, its free design variables) is read once on the client by `study_variant`; `problem_inputs` takes either
a path or one of these, so a Dask worker builds a case's NLP from what it was sent, without the files, the
study's folder or the client's working directory.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Literal

import casadi as ca
import numpy as np
from pydantic import BeforeValidator, Field, StrictBool

from cvtdesign.core.checks import check_layout
from cvtdesign.core.contact.laws import check_effects
from cvtdesign.design.dynamic_rows import dynamic_limits
from cvtdesign.design.objectives import OBJECTIVES
from cvtdesign.errors import InputError, shorten, suggest
from cvtdesign.io.fitted import read_fitted
from cvtdesign.io.limits import check_envelope_limits
from cvtdesign.io.schema import MAX_COUNT, EnvelopeSpec, Name, Num, Strict, VariantSpec, no_bool
from cvtdesign.io.units import check_range, dimension_of, kind_name, to_si
from cvtdesign.io.variant import grid, load_spec, parameter_value, quantity, resolve
from cvtdesign.io.yaml_file import read_spec

DEFAULT_MIN_NORMAL_FRACTION = 0.05   # default min_normal_force: this fraction of each roller's base preload

# integers and switches of a study file: YAML's true/false are not numbers, and 1 or "yes" is not a switch
Int = Annotated[int, BeforeValidator(no_bool)]
Weight = Annotated[float, BeforeValidator(no_bool)]


class DesignVar(Strict):
    """A free parameter of the base variant, between `lower` and `upper` (lower < upper, finite). Both bounds
    have the dimension of the parameter as the variant writes it (a parameter '60 mm' needs lengths like
    '30 mm'; a plain-number parameter, e.g. a ratio, plain-number bounds; an '= expression' parameter any
    dimension, the same for both bounds)."""
    lower: Num
    upper: Num
    variants: list[str] | None = None   # free only in these variant files (of batch.variants); default: all


class DutyPoint(Strict):
    gamma: Num          # an angle inside the envelope's γ range (`duty_cycle`)
    load: Num           # a torque inside the envelope's load range
    weight: Weight = 1.0   # finite, >= 0


class ObjectiveSpec(Strict):
    """What the study minimises: `kind` one of design.objectives.OBJECTIVES, and for the power-loss kinds an
    optional duty cycle of (γ, τ⊥) points with weights (without one, the mean over the envelope)."""
    kind: Literal[tuple(OBJECTIVES)] = "worst_alpha"
    duty_cycle: list[DutyPoint] | None = None


class Constraints(Strict):
    """Constraint settings: `traction_margin` a plain number in [0, 1); `clearance` a length >= 0 (at most
    1 m) between any two rollers; `envelope_radius` a length (0, 10 m]; `min_normal_force` a force > 0;
    `max_steering_torque` a torque (0, 1000 N·m]; `min_capacity` a torque (0, 10,000 N·m]; `min_life_h` a
    time > 0 with `life_duty` the duty file it holds over; `min_bandwidth_Hz` a frequency (0, 1000 Hz];
    `min_ratio_rate_deg_s` an angular rate (0, 1e5 deg/s]; `dynamic_gamma` angles within the envelope.
    Each is finite; plain numbers are SI, and an implausible plain length gets the unit it probably meant."""
    hertz_pressure: StrictBool = True
    traction_margin: Num | None = 0.2
    # N_i ≥ this at every contact and envelope point: a force ('5 N'); None: 5 % of each roller's preload at
    # the base design (DEFAULT_MIN_NORMAL_FRACTION). Not switchable off (bool is kept only to reject it).
    min_normal_force: bool | Num | None = None
    clearance: Num | None = "2 mm"
    envelope_radius: Num | None = None
    reach_gamma: StrictBool = True
    # the steering motor's torque, rolling and at standstill, at most this at every envelope point (core.steering)
    max_steering_torque: Num | None = None
    # every γ of the envelope carries |τ⊥| = this with the traction margin, normal force and Hertz limits
    min_capacity: Num | None = None
    # every roller's wear life over the duty cycle `life_duty` (a duty file, relative to the study) at least
    # this, a time ('50000 h'; design.life_rows, docs/life.md). A study sends its workers the duty as data
    # (design.cases.study_content), which life_duty then holds.
    min_life_h: Num | None = None
    life_duty: str | dict | None = None
    # the dynamic model's (design.dynamic_rows, docs/dynamics.md): the axis angle's −3 dB bandwidth at least this
    # frequency ('5 Hz'), and the steering able to change γ at least this fast ('100 deg/s') at a few envelope points
    min_bandwidth_Hz: Num | None = None
    min_ratio_rate_deg_s: Num | None = None
    dynamic_gamma: list[Num] | None = None    # the commanded γ where those two hold (default: five over the envelope)


class Multistart(Strict):
    starts: Int = 6
    seed: Annotated[Int, Field(ge=0)] = 0


class Batch(Strict):
    """What `cvtdesign study` runs as separate cases: every base variant × every combination of the swept
    (fixed) parameters × every multistart point, and one Pareto chain per variant × sweep combination."""
    variants: list[str] | None = None                 # default: [base]
    sweep: dict[str, list[Num]] = {}
    pareto: StrictBool = False


class Pareto(Strict):
    """ε-constraint sweep: minimise power loss subject to worst |α| ≤ ε, ε from the slip optimum to the
    loss optimum's slip, warm-started point to point."""
    points: Int = 8


class RobustSpec(Strict):
    """Optimise the worst case over a confidence region (design.robust): `over` what is uncertain (the
    calibration of the contact law), `confidence` the region's probability, in (0, 1)."""
    over: Literal["calibration"] = "calibration"
    confidence: Weight = 0.95


class StudySpec(Strict):
    name: Name          # part of the results folder's and the optimised variant's file names
    description: str = ""
    base: str
    effects: list[str] | None = None
    design: dict[str, DesignVar]
    objective: ObjectiveSpec = ObjectiveSpec()
    constraints: Constraints = Constraints()
    multistart: Multistart = Multistart()
    envelope: EnvelopeSpec | None = None              # default: the variant's envelope
    batch: Batch = Batch()
    pareto: Pareto = Pareto()
    max_iter: Int = 200
    robust: RobustSpec | None = None   # the worst case over the calibration's confidence region
    calibration: str | None = None     # a diagnosis report (cvtdesign diagnose --json) whose fitted effect
                                       # parameters the base variants carry (path relative to the study)


@dataclass
class Study:
    """A study file parsed once (`load_study`, the one place that reads one; the commands call it and pass
    this down): `path` the study file as the user names it (messages, relative file names, provenance),
    `spec` its contents, `base` the variant file its `base` names (in a worker: the StudyVariant the client
    sent, read from no file)."""
    path: str | Path
    spec: StudySpec
    base: Path | StudyVariant


def load_study(path) -> Study:
    """Read and check the study file at `path` (one InputError line for bad input)."""
    spec = read_spec(path, StudySpec, "name, base, design, objective")
    return Study(path, spec, next_to(path, "base", spec.base))


def next_to(study_path, field: str, name: str, what: str = "variant file") -> Path:
    """The file `name` that the study's `field` names, relative to the study file; one InputError line naming
    both when there is none or it is a folder (the file's own 'cannot read' named neither)."""
    f = Path(study_path).parent / name
    if f.is_dir():
        raise InputError(f"{study_path}: {field}: '{name}' is a folder; expected a {what}")
    if not f.is_file():
        raise InputError(f"{study_path}: {field}: no {what} '{name}' next to the study")
    if f.resolve() == Path(study_path).resolve():
        raise InputError(f"{study_path}: {field}: '{name}' is the study itself; expected a {what}")
    return f


@dataclass(frozen=True)
class StudyVariant:
    """A variant file as a study uses it, read on the client and sent to the workers as it is: `path` as the
    client names it (messages and an optimum's provenance header name it), `text` the file as written (an
    optimum's variant file is made from it, by `read_text` like a file), `spec` its contents with the study's
    calibration merged in, and `free` the study's design variables that are free in it."""
    path: str
    text: str
    spec: VariantSpec
    free: tuple[str, ...]

    @property
    def name(self) -> str:
        return Path(self.path).name

    def read_text(self) -> str:
        return self.text

    def __str__(self) -> str:
        return self.path


def study_variant(study_path, spec: StudySpec, base_file) -> StudyVariant:
    """The variant file `base_file` of the study at `study_path`, read (`load_spec`) with the fitted effect
    parameters of the study's calibration report merged in; a StudyVariant is returned as it is. Every bad
    input is one InputError line (an unreadable or invalid variant or calibration file, a missing file in a
    design variable's `variants`)."""
    if isinstance(base_file, StudyVariant):
        return base_file
    vspec = load_spec(base_file)
    if spec.calibration:
        fitted = read_fitted(next_to(study_path, "calibration", spec.calibration, "diagnosis report"))
        merged = {e: dict(ps) for e, ps in vspec.effect_parameters.items()}
        for e, ps in fitted.items():
            merged.setdefault(e, {}).update(ps)
        vspec = vspec.model_copy(update={"effect_parameters": merged})
    free = tuple(n for n in spec.design if _free_in(spec, n, base_file, study_path))
    return StudyVariant(str(base_file), Path(base_file).read_text(encoding="utf-8"), vspec, free)


def _free_in(spec: StudySpec, name: str, base_file: Path, study_path) -> bool:
    """Whether design variable `name` is free in the variant `base_file` (its `variants` list, if any, names
    variant files next to the study, as batch.variants does)."""
    only = spec.design[name].variants
    if only is None:
        return True
    files = [next_to(study_path, f"design.{name}.variants", v) for v in only]
    batch = {(Path(study_path).parent / v).resolve() for v in spec.batch.variants} if spec.batch.variants else None
    for v, f in zip(only, files):
        if batch is not None and f.resolve() not in batch:     # it would stay fixed without a word
            raise InputError(f"{study_path}: design.{name}.variants: '{v}' is not one of batch.variants; "
                             "expected variant files the study runs")
    return any(f.resolve() == Path(base_file).resolve() for f in files)


def _typed_value(raw, param: str, vspec, where: str) -> float:
    """A value for the variant parameter `param` (a design bound or a sweep value) in SI, finite, with the
    dimension of the parameter as the variant writes it (see DesignVar)."""
    value = parameter_value(raw, where, {})
    want, got = dimension_of(vspec.parameters[param]), dimension_of(raw)
    if want is not None and got is not None and want != got:
        raise InputError(f"{where}: '{shorten(raw)}' is {kind_name(got)} but the variant's parameter {param} is "
                         f"{kind_name(want)} ({param}: {shorten(vspec.parameters[param])}); expected the same kind")
    return value


def _check_bounds(n: str, spec: StudySpec, vspec, where: str) -> tuple[float, float]:
    lo = _typed_value(spec.design[n].lower, n, vspec, f"{where}: design.{n}.lower")
    hi = _typed_value(spec.design[n].upper, n, vspec, f"{where}: design.{n}.upper")
    d_lo, d_hi = dimension_of(spec.design[n].lower), dimension_of(spec.design[n].upper)
    if d_lo is not None and d_hi is not None and d_lo != d_hi:
        raise InputError(f"{where}: design.{n}: lower '{shorten(spec.design[n].lower)}' is {kind_name(d_lo)} but "
                         f"upper '{shorten(spec.design[n].upper)}' is {kind_name(d_hi)}; expected the same kind")
    return lo, hi


def _at_bound(vspec, base_file, overrides: dict, where: str, raw):
    """The layout with one design variable at a bound (the others at their base values), which must pass the
    checks the variant file itself gets: a radius bound of -20 mm would let the optimiser try rollers of
    negative radius. Only the fields are checked; collisions there are the design rows' business."""
    try:
        return resolve(vspec, str(base_file), overrides=overrides)
    except InputError as e:
        raise InputError(f"{where}: at '{shorten(raw)}' the variant is not valid: {e}") from None


def _contents(obj):
    """What a resolved layout is made of (numbers, names, nested), without its parameters, source and
    mounting plate (which only `export` draws), so that two layouts compare equal when they are the same
    machine."""
    if dataclasses.is_dataclass(obj):
        return [_contents(getattr(obj, f.name)) for f in dataclasses.fields(obj)
                if f.name not in ("parameters", "file", "frame")]
    if isinstance(obj, dict):
        return [(k, _contents(v)) for k, v in obj.items()]
    if isinstance(obj, (list, tuple)):
        return [_contents(v) for v in obj]
    return np.asarray(obj, float).tolist() if isinstance(obj, (np.ndarray, ca.DM)) else obj


def problem_inputs(study_path, spec: StudySpec, base_file, fixed: dict | None = None) -> tuple:
    """The checked inputs of a study's NLP for one variant file (a path, or a StudyVariant: then no file is
    read) and sweep point: (variant spec, base layout with the sweep point, free design variables, their
    lower and upper bounds [SI]). `study_path` only names the study in messages once the variant is read.
    Every bad input is one
    InputError line naming the study file and the field: an unknown sweep or design parameter, a swept
    design variable, inverted bounds, impossible geometry, and the study-wide settings (`check_settings`).
    Nothing is compiled (milliseconds), so `study` checks every case's inputs before it runs any."""
    where = str(study_path)
    variant = study_variant(study_path, spec, base_file)
    vspec = variant.spec
    fixed = fixed or {}
    for n in fixed:
        if n not in vspec.parameters:
            raise InputError(f"{where}: batch.sweep.{n}: the variant {variant.name} has no parameter '{n}'"
                             f"{suggest(n, vspec.parameters)}")
        if n in spec.design:
            raise InputError(f"{where}: batch.sweep.{n}: '{n}' is a design variable; sweep fixed parameters only")
    for n, values in spec.batch.sweep.items():      # of the parameter's kind, before the variant is built with them
        if n in vspec.parameters:
            for i, v in enumerate(values):
                _typed_value(v, n, vspec, f"{where}: batch.sweep.{n}[{i}]")
    try:
        base = resolve(vspec, str(base_file), overrides=fixed)
    except InputError as e:
        if not fixed:
            raise
        point = ", ".join(f"{n} = {v:.6g}" for n, v in fixed.items())
        raise InputError(f"{where}: batch.sweep: at {point} (SI) the variant is not valid: {e}") from None
    check_layout(base)
    names = list(variant.free)
    if not names:
        raise InputError(f"{where}: design: no design variables" + (f" for {variant.name}" if spec.design else ""))
    lower, upper = [], []
    for n in names:
        if n not in vspec.parameters:
            raise InputError(f"{where}: design.{n}: the variant {variant.name} has no parameter '{n}'"
                             f"{suggest(n, vspec.parameters)} (parameters: {', '.join(vspec.parameters) or 'none'})")
        lo, hi = _check_bounds(n, spec, vspec, where)
        if not lo < hi:
            what, hint = (("equal bounds", "; to fix a parameter, leave it out of design and set it in the variant")
                          if lo == hi else ("inverted bounds", ""))
            raise InputError(f"{where}: design.{n}: {what}: expected lower below upper, got lower "
                             f"{spec.design[n].lower} and upper {spec.design[n].upper}{hint}")
        ends = [_at_bound(vspec, base_file, {**fixed, n: value}, f"{where}: design.{n}.{end}",
                          getattr(spec.design[n], end)) for end, value in (("lower", lo), ("upper", hi))]
        if _contents(ends[0]) == _contents(ends[1]):
            raise InputError(f"{where}: design.{n}: no field of the variant {variant.name} uses the parameter '{n}' "
                             f"(the layout is the same at both bounds); expected a parameter that some field uses, as "
                             f"'= {n}' or in an expression")
        lower.append(lo)
        upper.append(hi)
    check_settings(study_path, spec, base)
    return vspec, base, names, np.array(lower), np.array(upper)


def on_study_envelope(spec: StudySpec, layout, where: str):
    """`layout` on the study's envelope (γ [rad] × τ⊥ [N m] grids), or as it is where the study sets none."""
    if spec.envelope is None:
        return layout
    return dataclasses.replace(layout, gamma_grid=grid(spec.envelope.gamma, "angle", f"{where}: envelope.gamma"),
                               load_grid=grid(spec.envelope.load, "torque", f"{where}: envelope.load"))


def check_settings(study_path, spec: StudySpec, base) -> None:
    """The study-wide settings the NLP reads, checked against the base layout `base`: the effects, the
    envelope, the constraint values, the duty cycle and the solver options (IPOPT's max_iter, the number
    of starts and of Pareto points)."""
    where = str(study_path)
    if spec.effects is not None:
        check_effects(spec.effects, f"{where}: effects", base.contact_law)
    on = on_study_envelope(spec, base, where)
    if spec.envelope is not None:
        check_envelope_limits(on, f"{where}: envelope")
    cs = spec.constraints
    if cs.traction_margin is not None:
        w = f"{where}: constraints.traction_margin"
        check_range(to_si(cs.traction_margin, "dimensionless", w), cs.traction_margin, w,
                    "traction margin", "dimensionless", 0.0, 1.0, hi_open=True)
    if cs.clearance is not None:
        w = f"{where}: constraints.clearance"
        check_range(to_si(cs.clearance, "length", w), cs.clearance, w, "clearance between rollers", "length",
                    0.0, 1.0, guess="mm")
    if cs.envelope_radius is not None:
        w = f"{where}: constraints.envelope_radius"
        check_range(to_si(cs.envelope_radius, "length", w), cs.envelope_radius, w, "assembly envelope radius",
                    "length", 0.0, 10.0, lo_open=True, guess="mm")
    if cs.min_bandwidth_Hz is not None or cs.min_ratio_rate_deg_s is not None:
        dynamic_limits(cs, where)
    if cs.max_steering_torque is not None:
        w = f"{where}: constraints.max_steering_torque"
        check_range(to_si(cs.max_steering_torque, "torque", w), cs.max_steering_torque, w, "steering torque",
                    "torque", 0.0, 1000.0, lo_open=True, guess="N*mm")
    if cs.min_capacity is not None:
        w = f"{where}: constraints.min_capacity"
        check_range(to_si(cs.min_capacity, "torque", w), cs.min_capacity, w, "load capacity", "torque", 0.0,
                    10000.0, lo_open=True, guess="N*mm")
    if OBJECTIVES[spec.objective.kind].life and cs.life_duty is None:
        raise InputError(f"{where}: constraints.life_duty: missing; expected the duty-cycle file the objective "
                         f"{spec.objective.kind} is taken over (e.g. ../studies/cobot_duty.yaml)")
    if cs.min_life_h is not None:
        w = f"{where}: constraints.min_life_h"
        check_range(to_si(cs.min_life_h, "time", w), cs.min_life_h, w, "minimum life", "time", 0.0, 1e10,
                    lo_open=True, guess="h")
        if cs.life_duty is None:
            raise InputError(f"{where}: constraints.life_duty: missing; expected the duty-cycle file that "
                             f"min_life_h holds over (e.g. ../studies/cobot_duty.yaml)")
    pre0 = np.array([float(r.preload) for r in base.rollers])
    min_normal_force(cs.min_normal_force, pre0, f"{where}: constraints.min_normal_force", base.parameters)
    duty_cycle(spec, on.gamma_grid, on.load_grid, where)
    check_counts(where, spec)
    if spec.robust is not None:
        if not 0 < spec.robust.confidence < 1:
            raise InputError(f"{where}: robust.confidence: expected a probability between 0 and 1 (e.g. 0.95), "
                             f"got {spec.robust.confidence:g}")
        if not OBJECTIVES[spec.objective.kind].robust:
            kinds = ", ".join(k for k, o in OBJECTIVES.items() if o.robust)
            raise InputError(f"{where}: robust: the worst case over the region is built for objective kind "
                             f"{kinds}; expected that kind with robust (got {spec.objective.kind})")


def duty_cycle(spec: StudySpec, gammas: np.ndarray, loads: np.ndarray, where: str) -> tuple:
    """The objective's duty cycle as arrays (γ [rad], τ⊥ [N·m], weight), each point inside the envelope the
    optimum is checked over (`gammas`, `loads`: a point outside it is one whose gross slip or lost contact no
    constraint sees; γ = 120° gave a mean power loss printed as valid) and a weight ≥ 0, not all 0."""
    points = []
    for i, d in enumerate(spec.objective.duty_cycle or []):
        w = f"{where}: objective.duty_cycle[{i}]"
        g, tau = quantity(d.gamma, "gamma", f"{w}.gamma"), quantity(d.load, "load", f"{w}.load")
        for name, v, axis, unit, k in (("γ", g, gammas, "deg", 180 / math.pi), ("τ⊥", tau, loads, "N·m", 1.0)):
            if not axis.min() - 1e-12 <= v <= axis.max() + 1e-12:
                raise InputError(f"{w}.{'gamma' if name == 'γ' else 'load'}: {name} = {v * k:g} {unit} is outside the "
                                 f"envelope the optimum is checked over ({name} {axis.min() * k:g}..{axis.max() * k:g} "
                                 f"{unit}); expected a point inside it (or a wider envelope)")
        if not (math.isfinite(d.weight) and d.weight >= 0):
            raise InputError(f"{w}.weight: expected a finite weight >= 0, got {d.weight}")
        points.append((g, tau, d.weight))
    if points and not sum(p[2] for p in points) > 0:
        raise InputError(f"{where}: objective.duty_cycle: every weight is 0; expected at least one positive weight")
    return tuple(np.array(a) for a in zip(*points)) if points else ()


def check_counts(where: str, spec: StudySpec) -> None:
    """The solver's counts (IPOPT's max_iter, the starts, the Pareto points) from 1 to MAX_COUNT, checked
    before a study builds its cases (3 million starts took 1.1 GB before this said no)."""
    for field_, value in (("max_iter", spec.max_iter), ("multistart.starts", spec.multistart.starts),
                          ("pareto.points", spec.pareto.points)):
        if not 1 <= value <= MAX_COUNT:
            raise InputError(f"{where}: {field_}: expected an integer from 1 to {MAX_COUNT}, got {value}")


def min_normal_force(raw, preloads: np.ndarray, where: str, names: dict) -> np.ndarray:
    """N_min per roller [N] from constraints.min_normal_force: a positive force (or an expression over the
    base variant's parameters), the same for every roller; None: DEFAULT_MIN_NORMAL_FRACTION of each
    roller's preload at the base design."""
    if raw is None:
        return DEFAULT_MIN_NORMAL_FRACTION * preloads
    if isinstance(raw, bool):
        raise InputError(f"{where}: expected a force like '5 N' (leave it out for {DEFAULT_MIN_NORMAL_FRACTION:.0%} "
                         f"of each roller's preload), got {raw!r}: the normal-force floor cannot be switched off")
    value = to_si(raw, "force", where, names)
    if not isinstance(value, float) or not value > 0:
        raise InputError(f"{where}: expected a positive force like '5 N', got '{raw}'")
    return np.full(preloads.size, value)

