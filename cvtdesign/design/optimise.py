"""Design optimisation: where should the rollers go and how big should they be.

A study file names a base variant, the variant parameters that are free (with bounds), an objective and
constraints. The model is compiled with the free parameters as CasADi symbols, so the objective and every
constraint over the operating envelope have exact derivatives (through the model's Newton solves by the
implicit function theorem); IPOPT solves the NLP from several space-filling starts.

Objectives: `worst_alpha` (max |α| over the envelope, as an epigraph variable t with −t ≤ α_k ≤ t),
`rms_alpha`, `power_loss` (weighted mean power loss over a duty cycle of (γ, τ⊥) points [W]).
Constraints: Hertz peak pressure ≤ the material's allowable, traction |F| ≤ (1 − margin)·μN (no gross
slip), normal force N ≥ N_min at every contact (the rollers stay in contact), roller–roller clearance
(distance of roller centres minus both radii: exact for rollers in one plane such as a tandem pair,
conservative otherwise), an assembly envelope radius, and the steering linkage still reaching every γ of
the envelope.

Normal force and traction. The model's normal forces come from the sphere's force balance on compliant
mounts, N_i = P_i + k_i n_i·δ, and nothing in that balance keeps them positive: a large lateral load can
unload a contact below zero, where the roller has lifted off and the model (creep, Hertz, traction) no
longer describes it. So
 * `normal_force` (always on): N_i ≥ N_min at every contact and envelope point, written N_i/P₀_i ≥
   N_min/P₀_i with P₀_i roller i's preload at the base design (rows of order 1); the constraint report
   gives its value, bound, slack in newtons and its multiplier per newton. `constraints.min_normal_force`
   is a force ('5 N'); left out (null) it is 5 % of each roller's base preload. It cannot be switched off:
   a design with a contact at N ≤ 0 is outside the model, whatever else the study asks for (a smaller
   positive floor is allowed).
 * `traction` is |F_i| − (1 − margin)·μ_i·N_i ≤ 0, not F/(μN) ≤ 1 − margin: the utilisation u = |F|/(μN) is
   negative when N < 0 and would pass the old row at a point that has lost contact. The row is
   (|F_i| − (1 − margin)·μ_i·N_i)/(μ_i·P_i), with the model's own μ_i (its `mu` output, friction effects
   included), |F| with the model's 1 mN smoothing (as in its utilisation), and P_i the design's preload
   (= (u_i − (1 − margin))·N_i/P_i: the old row's value wherever N = P). It is positive whenever N_i ≤ 0,
   and smooth through N = 0, where u has a pole; where N > 0 it has the sign of u − (1 − margin), so the
   feasible set, and every optimum with the contacts loaded, is the one of the utilisation row. (The
   alternative, keeping u and relying on the normal_force rows being present, would leave that pole in
   the rows IPOPT differentiates.)

After IPOPT, the optimum is checked on the whole envelope by the numeric model (`Problem.check`, which
compiles the layout at the optimum and runs `CompiledModel.evaluate` over every envelope point): a point
that did not converge, that has a contact at N ≤ 0 or a contact at |F| > μN fails it, and the solve is then
reported as failed (status 'Failed_Envelope_Check' with the counts; `success` False), so no variant file is
written for it (`write_variant` refuses to).

The formulation has a row per constraint per envelope point (6559 for the box placement study), but at an
optimum only a handful bind. `solve_from` therefore gives IPOPT a working set of envelope rows, checks
every row of the whole formulation at its solution, adds the violated ones and solves again (see there):
the same optimum as IPOPT on every row at once (`method="full"`), much faster (benchmarks/bench_optimise.py).
"""
from __future__ import annotations

import datetime
import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Literal

import casadi as ca
import numpy as np
import yaml
from pydantic import BeforeValidator, Field, StrictBool

from cvtdesign.core.checks import check_layout
from cvtdesign.core.effects import check_effects
from cvtdesign.core.geometry import _np, roller_pose, steering_angle_guess, steering_data
from cvtdesign.core.model import STATUS, compile_model
from cvtdesign.io.output import make_folder, write_file
from cvtdesign.errors import InputError, shorten, suggest
from cvtdesign.io.units import check_range, dimension_of, kind_name, registry, to_si
from cvtdesign.io.schema import EnvelopeSpec, Name, Num, Strict, no_bool
from cvtdesign.io.variant import grid, load_spec, parameter_value, quantity, resolve
from cvtdesign.io.yaml_file import read_spec

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
    gamma: Num          # an angle within ±90°
    load: Num           # a torque
    weight: Weight = 1.0   # finite, >= 0


class Objective(Strict):
    kind: Literal["worst_alpha", "rms_alpha", "power_loss"] = "worst_alpha"
    duty_cycle: list[DutyPoint] | None = None


class Constraints(Strict):
    """Constraint settings: `traction_margin` a plain number in [0, 1); `clearance` a length >= 0 (at most
    1 m) between any two rollers; `envelope_radius` a length (0, 10 m]; `min_normal_force` a force > 0.
    Each is finite; plain numbers are SI, and an implausible plain length gets the unit it probably meant."""
    hertz_pressure: StrictBool = True
    traction_margin: Num | None = 0.2
    # N_i ≥ this at every contact and envelope point: a force ('5 N'); None: 5 % of each roller's preload at
    # the base design (DEFAULT_MIN_NORMAL_FRACTION). Not switchable off (bool is kept only to reject it).
    min_normal_force: bool | Num | None = None
    clearance: Num | None = "2 mm"
    envelope_radius: Num | None = None
    reach_gamma: StrictBool = True


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


class StudySpec(Strict):
    name: Name          # part of the results folder's and the optimised variant's file names
    description: str = ""
    base: str
    effects: list[str] | None = None
    design: dict[str, DesignVar]
    objective: Objective = Objective()
    constraints: Constraints = Constraints()
    multistart: Multistart = Multistart()
    envelope: EnvelopeSpec | None = None              # default: the variant's envelope
    batch: Batch = Batch()
    pareto: Pareto = Pareto()
    max_iter: Int = 200


def load_study(path) -> tuple[StudySpec, Path]:
    where = str(path)
    spec = read_spec(path, StudySpec, "name, base, design, objective")
    base = (Path(path).parent / spec.base)
    if not base.exists():
        raise InputError(f"{where}: base: no variant file '{spec.base}' next to the study")
    return spec, base


IPOPT_OPTIONS = {"tol": 1e-8, "acceptable_tol": 1e-6, "hessian_approximation": "limited-memory",
                 "limited_memory_aug_solver": "extended"}   # few variables, many rows: cheaper than Sherman-Morrison
ACTIVE_TOL = 1e-7   # a constraint within this (relative) slack of its bound counts as active
NEAR_BINDING = 0.01  # working set: envelope points with a row within this fraction of its bound's scale
WORKING_SET_MAX = 2_000_000   # entries of the working set's row-selection matrix beyond which every row is used
DEFAULT_MIN_NORMAL_FRACTION = 0.05   # default min_normal_force: this fraction of each roller's base preload
VIOLATION_TOL = 1e-8  # a row beyond its bound by more than this (× max(1, |bound|)) is violated (IPOPT relaxes
#                      its bounds by bound_relax_factor = 1e-8 the same way)


@dataclass
class Problem:
    """The NLP of one study, in normalised design variables z ∈ [0, 1]^n (p = lower + (upper − lower)·z),
    with the epigraph variable t appended for worst-|α| objectives: x = (z, t).

    g (bounds g_lb ≤ g ≤ g_ub, one label and family per row) is the whole formulation: every constraint
    row at every point of the envelope. `solve_from` solves it with IPOPT over a working set of envelope
    points (see there); `solver` is IPOPT on all rows at once."""
    spec: StudySpec
    study_file: str
    base_file: Path
    names: list
    lower: np.ndarray
    upper: np.ndarray
    nx: int
    g_lb: np.ndarray
    g_ub: np.ndarray
    g_labels: list          # one label per constraint row
    g_family: list          # constraint family per row
    evaluate: ca.Function   # x (, eps) → (objective, g), all rows
    epigraph: bool
    start_t: ca.Function | None = None
    base_values: np.ndarray = field(default=None)
    parts: "_Parts" = None
    _solvers: dict = field(default_factory=dict)
    fixed: dict = field(default_factory=dict)     # sweep parameters (SI) set for this case
    g_report: np.ndarray = None   # per row: factor from g's units to the report's (P₀ for normal_force: N)
    vspec: object = None          # the base VariantSpec (to build the numeric layout of a design)
    motor_speed: float = None     # ω1 of the envelope [rad/s]

    @property
    def solver(self) -> ca.Function:
        """IPOPT on the whole formulation (every row at every envelope point), built on first use."""
        if "full" not in self._solvers:
            pt = self.parts
            self._solvers["full"] = _nlpsol(pt.x, pt.f, pt.g_full, pt.eps, self.spec.max_iter)
        return self._solvers["full"]

    def check(self, design: dict) -> "EnvelopeCheck":
        """The design (SI values of the design variables) on the whole envelope, by the numeric model: the
        base variant with this design and the case's sweep parameters, compiled and evaluated at every
        envelope point (see check_envelope)."""
        layout = resolve(self.vspec, str(self.base_file), overrides=self.fixed | dict(design))
        return check_envelope(compile_model(layout, effects=self.spec.effects), self.parts.gamma,
                              self.parts.load, self.motor_speed)


@dataclass
class _Parts:
    """The pieces both NLPs are built from. Per envelope point k, `point_rows` gives m rows (epigraph
    α ∓ t, Hertz p_max/p_allow per roller, traction (|F| − (1 − margin)μN)/(μP) per roller, normal force
    N/P₀ per roller, linkage misfit); row r of point k is
    row `pt_index[r] + k` of the whole formulation (the misfit row only depends on γ: it is row
    `reach_index[γ]`, taken at the γ's first point). Design rows (clearance, envelope radius, ε) depend on
    the design alone: `design_index`."""
    x: ca.MX
    eps: ca.MX
    f: ca.MX
    g_full: ca.MX
    g_design: ca.MX
    P0: ca.MX                 # Hertz peak pressure at the preload, per roller (design only)
    point_rows: ca.Function   # (x, γ, load, φ guess, p0) → m rows
    pt_lb: np.ndarray
    pt_ub: np.ndarray
    pt_index: np.ndarray      # per row of point_rows: offset in g (−1 for the misfit row)
    misfit_row: int | None
    reach_index: np.ndarray   # per γ: the row of its linkage misfit in g
    design_index: np.ndarray
    row_r: np.ndarray         # per row of g: its row of point_rows (−1: a design row)
    row_k: np.ndarray         # per row of g: its envelope point (the misfit row: the γ's first point)
    row_scale: np.ndarray     # per row of g: scale of its near-binding margin (NaN: the epigraph t)
    gamma: np.ndarray         # the envelope points
    load: np.ndarray
    phi0: np.ndarray
    gamma_of: np.ndarray      # γ index of each point
    screen: np.ndarray        # the points at the envelope's largest |load|, evaluated first


def _nlpsol(x, f, g, p, max_iter):
    opts = {"ipopt": IPOPT_OPTIONS | {"print_level": 0, "max_iter": max_iter, "sb": "yes"}, "print_time": False}
    return ca.nlpsol("design", "ipopt", {"x": x, "f": f, "g": g, "p": p}, opts)


def _free_in(spec: StudySpec, name: str, base_file: Path, study_path) -> bool:
    """Whether design variable `name` is free in the variant `base_file` (its `variants` list, if any, names
    variant files next to the study, as batch.variants does)."""
    only = spec.design[name].variants
    if only is None:
        return True
    files = [Path(study_path).parent / v for v in only]
    for v, f in zip(only, files):
        if not f.exists():
            raise InputError(f"{study_path}: design.{name}.variants: no variant file '{v}' next to the study")
    return any(f.resolve() == Path(base_file).resolve() for f in files)


def _unit_of(raw) -> str | None:
    if isinstance(raw, str) and not raw.strip().startswith("="):
        return str(registry().Quantity(raw.strip()).units)
    return None


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


def problem_inputs(study_path, spec: StudySpec, base_file: Path, fixed: dict | None = None) -> tuple:
    """The checked inputs of a study's NLP for one variant file and sweep point: (variant spec, base layout
    with the sweep point, free design variables, their lower and upper bounds [SI]). Every bad input is one
    InputError line naming the study file and the field: an unknown sweep or design parameter, a swept
    design variable, inverted bounds, impossible geometry, and the study-wide settings (`check_settings`).
    Nothing is compiled (milliseconds), so `study` checks every case's inputs before it runs any."""
    where = str(study_path)
    vspec = load_spec(base_file)
    fixed = fixed or {}
    for n in fixed:
        if n not in vspec.parameters:
            raise InputError(f"{where}: batch.sweep.{n}: the variant {base_file.name} has no parameter '{n}'"
                             f"{suggest(n, vspec.parameters)}")
        if n in spec.design:
            raise InputError(f"{where}: batch.sweep.{n}: '{n}' is a design variable; sweep fixed parameters only")
    base = resolve(vspec, str(base_file), overrides=fixed)
    check_layout(base)
    names = [n for n in spec.design if _free_in(spec, n, base_file, study_path)]
    if not names:
        raise InputError(f"{where}: design: no design variables" + (f" for {base_file.name}" if spec.design else ""))
    lower, upper = [], []
    for n in names:
        if n not in vspec.parameters:
            raise InputError(f"{where}: design.{n}: the variant {base_file.name} has no parameter '{n}'"
                             f"{suggest(n, vspec.parameters)} (parameters: {', '.join(vspec.parameters) or 'none'})")
        lo, hi = _check_bounds(n, spec, vspec, where)
        if not lo < hi:
            raise InputError(f"{where}: design.{n}: inverted bounds (lower {spec.design[n].lower} must be below "
                             f"upper {spec.design[n].upper})")
        lower.append(lo)
        upper.append(hi)
    for n, values in spec.batch.sweep.items():
        if n in vspec.parameters:
            for i, v in enumerate(values):
                _typed_value(v, n, vspec, f"{where}: batch.sweep.{n}[{i}]")
    check_settings(study_path, spec, base)
    return vspec, base, names, np.array(lower), np.array(upper)


def check_settings(study_path, spec: StudySpec, base) -> None:
    """The study-wide settings the NLP reads, checked against the base layout `base`: the effects, the
    envelope, the constraint values, the duty cycle and the solver options (IPOPT's max_iter, the number
    of starts and of Pareto points)."""
    where = str(study_path)
    if spec.effects is not None:
        check_effects(spec.effects, f"{where}: effects")
    if spec.envelope is not None:
        grid(spec.envelope.gamma, "angle", f"{where}: envelope.gamma")
        grid(spec.envelope.load, "torque", f"{where}: envelope.load")
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
    pre0 = np.array([float(r.preload) for r in base.rollers])
    _min_normal_force(cs.min_normal_force, pre0, f"{where}: constraints.min_normal_force", base.parameters)
    weights = []
    for i, d in enumerate(spec.objective.duty_cycle or []):
        quantity(d.gamma, "gamma", f"{where}: objective.duty_cycle[{i}].gamma")
        quantity(d.load, "load", f"{where}: objective.duty_cycle[{i}].load")
        if not (math.isfinite(d.weight) and d.weight >= 0):
            raise InputError(f"{where}: objective.duty_cycle[{i}].weight: expected a finite weight >= 0, got {d.weight}")
        weights.append(d.weight)
    if weights and not sum(weights) > 0:
        raise InputError(f"{where}: objective.duty_cycle: every weight is 0; expected at least one positive weight")
    for field_, value, least in (("max_iter", spec.max_iter, 1), ("multistart.starts", spec.multistart.starts, 1),
                                 ("pareto.points", spec.pareto.points, 1)):
        if value < least:
            raise InputError(f"{where}: {field_}: expected an integer >= {least}, got {value}")


def build_problem(study_path, spec: StudySpec | None = None, base_file: Path | None = None,
                  fixed: dict | None = None, objective: str | None = None) -> Problem:
    """The NLP of a study. `fixed` sets other variant parameters (SI) for a sweep case; `objective`
    overrides the study's objective kind ('pareto' builds the ε-constraint problem)."""
    if spec is None:
        spec, base_file = load_study(study_path)
    where = str(study_path)
    fixed = fixed or {}
    vspec, base, names, lower, upper = problem_inputs(study_path, spec, base_file, fixed)
    base_values = np.array([base.parameters[n] for n in names])

    p = ca.SX.sym("p", len(names))
    layout = resolve(vspec, str(base_file), overrides=fixed | {n: p[i] for i, n in enumerate(names)})
    model = compile_model(layout, effects=spec.effects, design=p)
    gammas, loads = base.gamma_grid, base.load_grid
    if spec.envelope is not None:
        gammas = grid(spec.envelope.gamma, "angle", f"{where}: envelope.gamma")
        loads = grid(spec.envelope.load, "torque", f"{where}: envelope.load")
    G, T = np.meshgrid(gammas, loads, indexing="ij")
    g_pts, l_pts = G.ravel(), T.ravel()
    phi0, _ = steering_angle_guess(*steering_data(base), g_pts)
    theta = np.array(model.param_values)
    npts, nload = g_pts.size, G.shape[1]
    w1 = base.motor_speed
    rn = model.roller_names
    nc = len(rn)

    kind = objective or spec.objective.kind
    epigraph = kind in ("worst_alpha", "pareto")
    z = ca.MX.sym("z", len(names))
    t = ca.MX.sym("t") if epigraph else ca.MX(0, 1)
    eps = ca.MX.sym("eps")          # ε of the Pareto sweep: worst |α| ≤ ε [deg]
    x = ca.vertcat(z, t)
    P = ca.DM(lower) + ca.DM(upper - lower) * z
    P0 = model.hertz_p0(P)
    duty = spec.objective.duty_cycle if kind in ("power_loss", "pareto") else None
    grid_objective = kind == "rms_alpha" or (kind in ("power_loss", "pareto") and not duty)

    # ---- the rows of one envelope point, as a function of (x, γ, load, φ guess, p0)
    cs = spec.constraints
    margin = None if cs.traction_margin is None else \
        float(parameter_value(cs.traction_margin, f"{where}: constraints.traction_margin", {}))
    allow = [r.material.p_allow if cs.hertz_pressure else None for r in layout.rollers]
    pre0 = np.array([float(r.preload) for r in base.rollers])        # P₀: the preloads at the base design
    n_min = _min_normal_force(cs.min_normal_force, pre0, f"{where}: constraints.min_normal_force", base.parameters)
    need = (["alpha"] if epigraph else []) + ["N"] + \
        (["F_t", "F_a", "mu"] if margin is not None else []) + (["steer_misfit"] if cs.reach_gamma else [])
    preload = ca.Function("preload", [p], [ca.vertcat(*[r.preload for r in layout.rollers])])   # P(design)
    obj_name = "alpha" if kind == "rms_alpha" else "power_loss"

    def point_function(outputs):
        """(x, γ, load, φ guess, p0) → the point's rows (and the objective's per-point value), evaluating
        only the model outputs they need; blocks: (lb, ub, family, label of a point, margin scale)."""
        xs, gs, ls, ps = ca.MX.sym("x", x.shape[0]), ca.MX.sym("gamma"), ca.MX.sym("load"), ca.MX.sym("phi0")
        p0s = ca.MX.sym("p0", nc)
        Ps = ca.DM(lower) + ca.DM(upper - lower) * xs[:len(names)]
        out = dict(zip(outputs, model.point_function(outputs).call([gs, w1, ls, 0.0, ps, theta, Ps]))) \
            if outputs else {}
        rows_, blocks = [], []
        if epigraph:
            a_deg = out["alpha"] * (180 / np.pi)
            rows_ += [a_deg - xs[len(names)], -a_deg - xs[len(names)]]
            blocks += [(-np.inf, 0.0, "worst_alpha", lambda s: f"α ≤ t at {s}", None),
                       (-np.inf, 0.0, "worst_alpha", lambda s: f"−α ≤ t at {s}", None)]
        if any(a is not None for a in allow):
            pm = model.peak_pressure(out["N"], p0s, Ps)
            for i, a in enumerate(allow):
                if a is not None:
                    rows_.append(pm[i] / a)
                    blocks.append((-np.inf, 1.0, "hertz_pressure", lambda s, i=i: f"p_max/p_allow of {rn[i]} at {s}", 1.0))
        if margin is not None:
            # (|F| − (1 − margin)μN)/(μP) ≤ 0: positive wherever N ≤ 0 (u = |F|/(μN) is negative there)
            f_abs = ca.sqrt(out["F_t"] ** 2 + out["F_a"] ** 2 + 1e-6)       # the model's 1 mN smoothing
            mu_p = out["mu"] * preload(Ps)
            for i in range(nc):
                rows_.append((f_abs[i] - (1 - margin) * out["mu"][i] * out["N"][i]) / mu_p[i])
                blocks.append((-np.inf, 0.0, "traction",
                               lambda s, i=i: f"(|F| − {1 - margin:g}μN)/(μP) of {rn[i]} at {s}", 1 - margin))
        for i in range(nc):       # N ≥ N_min, over P₀ (reported in newtons: g_report)
            rows_.append(out["N"][i] / pre0[i])
            blocks.append((n_min[i] / pre0[i], np.inf, "normal_force", lambda s, i=i: f"N [N] of {rn[i]} at {s}", 1.0))
        if cs.reach_gamma:
            rows_.append(out["steer_misfit"])
            blocks.append((-np.inf, 1e-6, "reach_gamma", None, 1e-6))
        res = [ca.vertcat(*rows_) if rows_ else ca.MX(0, 1)]
        if obj_name in outputs and grid_objective:
            res.append(out[obj_name] * (180 / np.pi if obj_name == "alpha" else 1))
        return ca.Function("point_rows", [xs, gs, ls, ps, p0s], res), blocks

    point_rows, blocks = point_function(need)
    point_all = point_function(list(dict.fromkeys(need + [obj_name])))[0] if grid_objective else None
    misfit_row = len(blocks) - 1 if cs.reach_gamma else None
    m = len(blocks)

    # ---- the whole formulation: every row at every point, then the design-only rows
    rows, lb, ub, labels, family = [], [], [], [], []

    def add(expr, lo, hi, fam, labs):
        expr = ca.vec(expr)
        start = len(lb)
        rows.append(expr)
        lb.extend(np.broadcast_to(lo, expr.shape[0]))
        ub.extend(np.broadcast_to(hi, expr.shape[0]))
        labels.extend(labs)
        family.extend([fam] * expr.shape[0])
        return start

    pt_label = [f"γ={np.degrees(g):+.0f}° τ⊥={l:+.2g}" for g, l in zip(g_pts, l_pts)]
    grid_args = [x, g_pts[None, :], l_pts[None, :], phi0[None, :], P0]
    if grid_objective:              # the objective's values come from the same Newton solves as the rows
        M, obj_grid = point_all.map(npts, "serial").call(grid_args)
    else:
        M, obj_grid = point_rows.map(npts, "serial").call(grid_args)[0], None
    first = np.arange(0, npts, nload)          # one point per γ (the linkage misfit depends on γ only)
    pt_index = np.full(m, -1)
    reach_index = np.zeros(0, int)
    for r, (lo, hi, fam, lab, _) in enumerate(blocks):
        if r == misfit_row:
            start = add(M[r, first].T, lo, hi, fam, [f"linkage misfit at γ={np.degrees(g_pts[k]):+.0f}°" for k in first])
            reach_index = start + np.arange(first.size)
        else:
            pt_index[r] = add(M[r, :].T, lo, hi, fam, [lab(s) for s in pt_label])
    design_start, n_point_blocks = len(lb), len(rows)
    R = layout.sphere_radius
    design_rows, design_spec = [], []     # SX rows in p, compiled into one function below
    if cs.clearance is not None:
        c = float(parameter_value(cs.clearance, f"{where}: constraints.clearance", {}))
        phis = np.unique(np.round(phi0, 12))[:: max(1, len(np.unique(phi0)) // 5)]
        for (a, ra), (b, rb) in itertools.combinations(enumerate(layout.rollers), 2):
            # two fixed rollers, or two turned by the same angle about the same fork axis, keep their
            # distance at every φ: one row (the same row at each φ would be a duplicate constraint)
            rigid = (ra.fork_axis is None and rb.fork_axis is None) or (
                ra.fork_axis is not None and rb.fork_axis is not None and ra.fork_sign == rb.fork_sign
                and np.allclose(_np(ra.fork_axis), _np(rb.fork_axis)))
            gaps, labs = [], []
            for ph in phis[:1] if rigid else phis:
                ca_ = (R + ra.radius) * roller_pose(ra, ph)[0]
                cb = (R + rb.radius) * roller_pose(rb, ph)[0]
                gaps.append(ca.norm_2(ca_ - cb) - ra.radius - rb.radius)
                labs.append(f"clearance {rn[a]}–{rn[b]}" + ("" if rigid else f" at φ={np.degrees(ph):+.0f}°"))
            design_rows += gaps
            design_spec.append((len(gaps), c, np.inf, "clearance", labs))
    if cs.envelope_radius is not None:
        e = float(parameter_value(cs.envelope_radius, f"{where}: constraints.envelope_radius", {}))
        design_rows += [R + 2 * r.radius for r in layout.rollers]
        design_spec.append((len(rn), -np.inf, e, "envelope_radius", [f"extent of {r}" for r in rn]))
    if design_rows:
        D = ca.Function("design_rows", [p], [ca.cse(ca.vertcat(*design_rows))])(P)
        at = 0
        for size, lo, hi, fam, labs in design_spec:
            add(D[at: at + size], lo, hi, fam, labs)
            at += size
    if kind == "pareto":
        add(t - eps, -np.inf, 0, "epsilon", ["worst |α| ≤ ε"])
    g_full = ca.vertcat(*rows)
    design_index = np.arange(design_start, len(lb))
    # the design rows on their own (a slice of g_full would still depend on every envelope point)
    g_design = ca.vertcat(*rows[n_point_blocks:]) if design_index.size else ca.MX(0, 1)

    # ---- the objective
    if epigraph:
        f = t
    if kind == "rms_alpha":
        f = ca.sqrt(ca.sumsqr(obj_grid) / npts)
    elif kind in ("power_loss", "pareto"):
        if duty:
            dg = np.array([parameter_value(d.gamma, f"{where}: objective.duty_cycle.gamma", {}) for d in duty])
            dl = np.array([parameter_value(d.load, f"{where}: objective.duty_cycle.load", {}) for d in duty])
            w = np.array([d.weight for d in duty])
            dphi, _ = steering_angle_guess(*steering_data(base), dg)
            loss = model.point_function(["power_loss"]).map(len(dg), "serial")(dg, w1, dl, 0.0, dphi, theta, P)
            f = ca.dot(ca.DM(w / w.sum()), ca.vec(loss))
        else:
            f = ca.sum2(obj_grid) / npts

    evaluate = ca.Function("evaluate", [x, eps], [f, g_full]) if kind == "pareto" else ca.Function("evaluate", [x], [f, g_full])
    start_t = None
    if epigraph:
        alpha_grid = model.point_function(["alpha"]).map(npts, "serial")(g_pts, w1, l_pts, 0.0, phi0, theta, P)
        start_t = ca.Function("start_t", [z], [ca.mmax(ca.fabs(alpha_grid)) * (180 / np.pi)])
    # which point row (r) of which point (k) each row of g is; −1 for the design rows
    row_r, row_k, row_scale = np.full(len(lb), -1), np.full(len(lb), -1), np.full(len(lb), np.nan)
    for r, b in enumerate(blocks):
        idx = reach_index if r == misfit_row else pt_index[r] + np.arange(npts)
        row_r[idx], row_k[idx] = r, first if r == misfit_row else np.arange(npts)
        row_scale[idx] = np.nan if b[4] is None else b[4]
    big = np.abs(l_pts) >= np.max(np.abs(l_pts)) * (1 - 1e-12)
    parts = _Parts(x, eps, f, g_full, g_design, P0, point_rows, np.array([b[0] for b in blocks], float),
                   np.array([b[1] for b in blocks], float), pt_index, misfit_row, reach_index, design_index,
                   row_r, row_k, row_scale, g_pts, l_pts, phi0, np.arange(npts) // nload,
                   np.flatnonzero(big))
    g_report = np.ones(len(lb))
    nf = [r for r, b in enumerate(blocks) if b[2] == "normal_force"]
    for i, r in enumerate(nf):
        g_report[pt_index[r] + np.arange(npts)] = pre0[i]
    return Problem(spec, where, base_file, names, lower, upper, x.shape[0], np.array(lb), np.array(ub),
                   labels, family, evaluate, epigraph, start_t, base_values, parts, fixed=dict(fixed),
                   g_report=g_report, vspec=vspec, motor_speed=float(w1))


def _min_normal_force(raw, preloads: np.ndarray, where: str, names: dict) -> np.ndarray:
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


@dataclass
class Solution:
    status: str
    success: bool
    objective: float
    z: np.ndarray
    design: dict
    g: np.ndarray
    lam_g: np.ndarray
    lam_x: np.ndarray
    iterations: int
    start: int
    rounds: int = 1          # working-set rounds (IPOPT solves)
    points: int = 0          # envelope points in the final working set
    check: "EnvelopeCheck | None" = None   # the optimum on the whole envelope (None: IPOPT did not succeed)
    ipopt_status: str = ""   # IPOPT's return status (`status` says Failed_Envelope_Check when the check fails)


@dataclass
class EnvelopeCheck:
    """A design on the whole envelope by the numeric model: how many points did not converge, lost
    contact (N ≤ 0 at some contact) or slip grossly (N > 0 but |F| > μN at some contact)."""
    points: int
    not_converged: int
    lost_contact: int
    gross_slip: int
    min_normal_force: float    # [N] smallest N over the points that pass (NaN: none passes)
    max_utilisation: float     # largest |F|/(μN) over the points that pass
    worst: str = ""            # a failing point of the most serious kind, why, and at which contact

    @property
    def failed(self) -> int:
        return self.not_converged + self.lost_contact + self.gross_slip

    @property
    def ok(self) -> bool:
        return self.failed == 0

    def summary(self) -> str:
        return (f"{self.failed} of {self.points} envelope points: {self.lost_contact} lost contact (N ≤ 0), "
                f"{self.gross_slip} gross slip (|F| > μN), {self.not_converged} not converged")

    def as_dict(self) -> dict:
        return {"points": self.points, "failed": self.failed, "not_converged": self.not_converged,
                "lost_contact": self.lost_contact, "gross_slip": self.gross_slip,
                "min_normal_force_N": self.min_normal_force, "max_utilisation": self.max_utilisation,
                "worst": self.worst}


def check_envelope(model, gammas, loads, speeds=None) -> EnvelopeCheck:
    """Evaluate a numeric CompiledModel at the operating points (γ [rad], τ⊥ [N m], broadcastable; speeds
    [rad/s], default the layout's) and count the points outside the model's physics by the model's own
    `status` (not converged, lost contact: N ≤ 0, gross slip: |F| > μN), naming the first failure of the
    most serious kind and the contact behind it."""
    res = model.evaluate(gammas, loads, speeds)
    st, contact = res["status"].ravel(), res["failed_contact"].ravel()
    n = st.size
    N, U = np.reshape(res["N"], (-1, n)), np.reshape(res["utilisation"], (-1, n))
    ok = st == STATUS.index("ok")
    g, l = (np.broadcast_to(a, res["status"].shape).ravel() for a in (res["gamma_cmd"], res["load"]))
    worst = ""
    for code, what in ((2, "lost contact (N ≤ 0)"), (3, "gross slip (|F| > μN)"), (1, "not converged")):
        if (st == code).any():
            k = int(np.flatnonzero(st == code)[0])
            who = f" at {model.roller_names[contact[k]]}" if contact[k] >= 0 else ""
            worst = f"γ={np.degrees(g[k]):+.0f}° τ⊥={l[k]:+.3g}: {what}{who}"
            break
    return EnvelopeCheck(n, int((st == 1).sum()), int((st == 2).sum()), int((st == 3).sum()),
                         float(np.min(N[:, ok])) if ok.any() else float("nan"),
                         float(np.max(U[:, ok])) if ok.any() else float("nan"), worst)


def _bucket(k: int) -> int:
    """Capacity for k working-set points or rows: a few sizes, so that solvers are reused across rounds
    and starts (padding costs a little evaluation, a new size a new solver)."""
    if k == 0:
        return 0
    size = 1
    while size < k:
        size = size + 1 if size < 4 else int(size * 1.5)
    return size


def _ws_solver(problem: Problem, npoints: int, nrows: int) -> ca.Function:
    """IPOPT on the design rows and `nrows` rows of `npoints` envelope points: the points' (γ, load,
    φ guess) and a 0/1 matrix selecting the rows are parameters, so one solver serves every working set of
    that capacity."""
    key = ("ws", npoints, nrows)
    if key not in problem._solvers:
        pt = problem.parts
        m = pt.pt_lb.size
        data = ca.MX.sym("points", 3, npoints)
        select = ca.MX.sym("select", nrows, m * npoints)
        g = pt.g_design
        if npoints and nrows:
            rows = pt.point_rows.map(npoints, "serial").call([pt.x, data[0, :], data[1, :], data[2, :], pt.P0])[0]
            g = ca.vertcat(g, ca.mtimes(select, ca.vec(rows)))
        problem._solvers[key] = _nlpsol(pt.x, pt.f, g, ca.vertcat(pt.eps, ca.vec(data), ca.vec(select)),
                                        problem.spec.max_iter)
    return problem._solvers[key]


def _rows_at(problem: Problem, x, points) -> np.ndarray:
    """The point rows (m × len(points)) at x for the given envelope points."""
    pt = problem.parts
    key = ("rows", len(points))
    if key not in problem._solvers:
        data = ca.MX.sym("points", 3, len(points))
        rows = pt.point_rows.map(len(points), "serial").call([pt.x, data[0, :], data[1, :], data[2, :], pt.P0])[0]
        problem._solvers[key] = ca.Function("rows_at", [pt.x, data], [rows])
    data = np.vstack([pt.gamma[points], pt.load[points], pt.phi0[points]])
    return np.asarray(problem._solvers[key](x, data)).reshape(-1, len(points), order="F")


def _near_binding(problem: Problem, g: np.ndarray, t: float, rows=None) -> np.ndarray:
    """Mask over g (or over the full rows listed in `rows`): point rows within NEAR_BINDING of their bound's
    scale, or beyond it (the epigraph rows α ∓ t: within NEAR_BINDING·t of t)."""
    pt = problem.parts
    rows = np.arange(problem.g_lb.size) if rows is None else rows
    scale = np.where(np.isnan(pt.row_scale[rows]), max(abs(t), 1e-6), pt.row_scale[rows])
    with np.errstate(invalid="ignore"):
        slack = np.minimum(problem.g_ub[rows] - g, g - problem.g_lb[rows])
    return (pt.row_k[rows] >= 0) & (slack <= NEAR_BINDING * scale)


def solve_from(problem: Problem, z0, start_index=0, eps: float = 0.0, warm: Solution | None = None,
               method: Literal["working_set", "full"] = "working_set") -> Solution:
    """Solve from normalised design z0 (and, for the Pareto problem, bound ε on worst |α| [deg]);
    `warm` passes a neighbouring solution's multipliers as a warm start.

    method 'working_set': IPOPT on the objective, the design rows and a working set of envelope rows only,
    an active-set / cutting-plane scheme. The first working set: the rows near their bound at the
    envelope's largest |load| (where slip, forces and pressures peak; near: within NEAR_BINDING of the
    bound's scale, the epigraph rows within NEAR_BINDING·t of the worst |α|). After each solve every row of
    the whole formulation is evaluated; the violated rows (with the rows now near their bound) join the
    set and IPOPT solves again from there, until no row anywhere is violated by more than VIOLATION_TOL.
    The result is then an optimum of the whole formulation (the rows left out are inactive: multiplier 0);
    g and lam_g are returned for every row. 'full': IPOPT on every row at once."""
    pt = problem.parts
    n = len(problem.names)
    lbx = [0.0] * n + ([0.0] if problem.epigraph else [])
    ubx = [1.0] * n + ([np.inf] if problem.epigraph else [])
    z0 = np.asarray(z0, float)

    def every_row(x0, lam, iters=0, rounds=0):
        extra = {} if lam is None else {"lam_g0": lam}
        sol = problem.solver(x0=x0, lbx=lbx, ubx=ubx, lbg=problem.g_lb, ubg=problem.g_ub, p=eps, **extra)
        st = problem.solver.stats()
        return _solution(problem, sol, st, np.asarray(sol["g"]).ravel(), np.asarray(sol["lam_g"]).ravel(),
                         iters + int(st["iter_count"]), start_index, rounds + 1, pt.gamma.size)

    if method == "full":
        return every_row(list(z0) + ([float(problem.start_t(z0)) * 1.05 + 1e-3] if problem.epigraph else []),
                         None if warm is None else warm.lam_g)

    # the start: the rows at the largest |load| give t0 and the first working set
    m = pt.pt_lb.size
    rows = _rows_at(problem, np.append(z0, 0.0) if problem.epigraph else z0, pt.screen)
    t0 = worst = 0.0
    if problem.epigraph:
        worst = float(np.max(np.abs(rows[0])))                # rows[0] = α − t at t = 0
        rows[:2] -= worst                                       # the epigraph rows at t = worst |α|
        t0 = worst * 1.05 + 1e-3
    full = np.array([[pt.pt_index[r] + k if r != pt.misfit_row else pt.reach_index[pt.gamma_of[k]]
                      for k in pt.screen] for r in range(m)], int)
    work = np.unique(full[_near_binding(problem, rows.ravel(), worst, full.ravel()).reshape(full.shape)])
    x0 = np.append(z0, t0) if problem.epigraph else z0
    lam_full = None if warm is None else warm.lam_g
    nd = pt.design_index.size
    iters, rounds = 0, 0
    while True:
        rounds += 1
        points = np.unique(pt.row_k[work])
        npoints, nrows = _bucket(points.size), _bucket(work.size)
        if nrows * m * npoints > WORKING_SET_MAX:      # most rows bind somewhere: every row at once is cheaper
            return every_row(x0, lam_full, iters, rounds - 1)
        slots = np.concatenate([points, np.full(npoints - points.size, points[0] if points.size else 0, int)])
        select = np.zeros((nrows, m * npoints))
        select[np.arange(work.size), np.searchsorted(points, pt.row_k[work]) * m + pt.row_r[work]] = 1
        pad = nrows - work.size
        lbg = np.concatenate([problem.g_lb[pt.design_index], problem.g_lb[work], np.full(pad, -np.inf)])
        ubg = np.concatenate([problem.g_ub[pt.design_index], problem.g_ub[work], np.full(pad, np.inf)])
        data = np.vstack([pt.gamma[slots], pt.load[slots], pt.phi0[slots]])
        extra = {} if lam_full is None else \
            {"lam_g0": np.concatenate([lam_full[pt.design_index], lam_full[work], np.zeros(pad)])}
        solver = _ws_solver(problem, npoints, nrows)
        sol = solver(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg,
                     p=np.concatenate([[eps], data.ravel(order="F"), select.ravel(order="F")]), **extra)
        st = solver.stats()
        iters += int(st["iter_count"])
        xs = np.asarray(sol["x"]).ravel()
        lam_ws = np.asarray(sol["lam_g"]).ravel()
        lam = np.zeros(problem.g_lb.size)
        lam[pt.design_index] = lam_ws[:nd]
        lam[work] = lam_ws[nd: nd + work.size]
        g = np.asarray(problem.evaluate(*([xs, eps] if len(problem.evaluate.name_in()) == 2 else [xs]))[1]).ravel()
        ok = bool(st["success"]) or st["return_status"] == "Solved_To_Acceptable_Level"
        tol = VIOLATION_TOL * np.maximum(1.0, np.minimum(np.abs(problem.g_lb), np.abs(problem.g_ub)))
        violated = (g > problem.g_ub + tol) | (g < problem.g_lb - tol)
        violated[work] = False
        violated[pt.design_index] = False
        if not ok or not violated.any():
            return _solution(problem, sol, st, g, lam, iters, start_index, rounds, points.size)
        # the violated rows join, with every row now near its bound; solve again from here
        near = _near_binding(problem, g, xs[-1] if problem.epigraph else 0.0)
        work = np.union1d(work, np.flatnonzero(violated | near))
        x0, lam_full = xs, lam


def _solution(problem, sol, st, g, lam_g, iterations, start_index, rounds, points) -> Solution:
    """The Solution of an IPOPT run; a successful one is checked on the whole envelope by the numeric model
    (Problem.check) and reported as failed ('Failed_Envelope_Check') if any point is outside the physics."""
    n = len(problem.names)
    zs = np.asarray(sol["x"]).ravel()[:n]
    values = problem.lower + (problem.upper - problem.lower) * zs
    design = dict(zip(problem.names, values.tolist()))
    status = st["return_status"]
    success = bool(st["success"]) or status == "Solved_To_Acceptable_Level"
    check = None
    if success:
        check = problem.check(design)
        if not check.ok:
            success, status = False, f"Failed_Envelope_Check: {check.summary()}"
    return Solution(status, success, float(sol["f"]), zs, design, g, lam_g,
                    np.asarray(sol["lam_x"]).ravel()[:n], iterations, start_index, rounds, points, check,
                    st["return_status"])


def starts(problem: Problem) -> np.ndarray:
    """The base design first, then a Latin hypercube of the design box."""
    from scipy.stats import qmc

    n = len(problem.names)
    z_base = np.clip((problem.base_values - problem.lower) / (problem.upper - problem.lower), 0, 1)
    k = max(problem.spec.multistart.starts, 1)
    rest = qmc.LatinHypercube(d=n, seed=problem.spec.multistart.seed).random(k - 1) if k > 1 else np.zeros((0, n))
    return np.vstack([z_base[None, :], rest])


def distinct_optima(solutions: list[Solution], tol=1e-3) -> list[tuple[Solution, int]]:
    """Group successful solutions whose designs (normalised) agree within tol: (best of group, count)."""
    groups: list[list[Solution]] = []
    for s in sorted((s for s in solutions if s.success), key=lambda s: s.objective):
        for grp in groups:
            if np.max(np.abs(grp[0].z - s.z)) < tol:
                grp.append(s)
                break
        else:
            groups.append([s])
    return [(grp[0], len(grp)) for grp in groups]


def constraint_report(problem: Problem, sol: Solution) -> list[dict]:
    """Per constraint family, the most binding row: value, bound, slack, multiplier and whether active.
    Values, bounds, slacks and multipliers are in the row's report units (normal_force: newtons, the
    multiplier per newton; the others as in g)."""
    rows = []
    scale = np.ones(problem.g_lb.size) if problem.g_report is None else problem.g_report
    for fam in dict.fromkeys(problem.g_family):
        idx = [i for i, f in enumerate(problem.g_family) if f == fam]
        slack = np.minimum(sol.g[idx] - problem.g_lb[idx], problem.g_ub[idx] - sol.g[idx])
        j = idx[int(np.argmin(slack))]
        bound = problem.g_ub[j] if np.isfinite(problem.g_ub[j]) and problem.g_ub[j] - sol.g[j] <= sol.g[j] - problem.g_lb[j] \
            else problem.g_lb[j]
        s = float(np.min(slack))
        active = bool(s <= ACTIVE_TOL * max(1.0, abs(bound)))
        lam = float(np.max(np.abs(sol.lam_g[idx]) / scale[idx]))
        rows.append({"name": fam, "where": problem.g_labels[j], "value": float(sol.g[j] * scale[j]),
                     "bound": float(bound * scale[j]), "slack": s * float(scale[j]), "multiplier": lam,
                     "active": active})
    for i, n in enumerate(problem.names):
        at_lo, at_hi = sol.z[i] < 1e-6, sol.z[i] > 1 - 1e-6
        if at_lo or at_hi:
            rows.append({"name": f"bound {n}", "where": "lower" if at_lo else "upper",
                         "value": sol.design[n], "bound": float(problem.lower[i] if at_lo else problem.upper[i]),
                         "slack": 0.0, "multiplier": float(abs(sol.lam_x[i]) / (problem.upper[i] - problem.lower[i])),
                         "active": True})
    return rows


def variant_text(problem: Problem, sol: Solution, out_dir: Path, name: str | None = None) -> tuple[Path, str]:
    """(path, text) of the optimised design as a variant file `compare` reads, with a provenance header
    (name: default '<base variant>_<study>'): the base variant with the optimised design variables, the
    case's sweep parameters and the study's envelope (when it sets one). Refuses a solution that did not
    succeed, the envelope check included (no variant file for a design outside the model's physics)."""
    if not sol.success:
        raise ValueError(f"not writing a variant for a failed solve (status {sol.status})")

    data = yaml.safe_load(problem.base_file.read_text())
    # the design variables, the case's sweep parameters, and the envelope the design was optimised over
    # (a study's narrower envelope is what the clearance and reach constraints held for)
    if problem.spec.envelope is not None:
        data["envelope"] = problem.spec.envelope.model_dump(exclude_unset=True)
    for n, v in (problem.fixed | sol.design).items():
        unit = _unit_of(data["parameters"][n])
        if unit:
            q = registry().Quantity(v, registry().Quantity(1, unit).to_base_units().units).to(unit)
            data["parameters"][n] = f"{q.magnitude:.6g} {unit}"
        else:
            data["parameters"][n] = float(f"{v:.6g}")
    name = name or f"{data['name']}_{problem.spec.name}"
    data["description"] = f"{problem.spec.name} optimum of {data['name']}. " + problem.spec.description
    data["name"] = name
    header = (f"# Optimised by `cvtdesign optimise {problem.study_file}`\n"
              f"# study: {problem.spec.name}; objective: {problem.spec.objective.kind} = {sol.objective:.6g}\n"
              f"# date: {datetime.datetime.now().isoformat(timespec='seconds')}; solver: IPOPT, status "
              f"{sol.status}, {sol.iterations} iterations, start {sol.start}\n"
              f"# base variant: {problem.base_file}\n")
    return Path(out_dir) / f"{name}.yaml", header + yaml.safe_dump(data, sort_keys=False, allow_unicode=True)


def write_variant(problem: Problem, sol: Solution, out_dir: Path, name: str | None = None) -> Path:
    """Write `variant_text` into `out_dir` (an output folder: created if missing); returns the path."""
    path, text = variant_text(problem, sol, out_dir, name)
    make_folder(out_dir, kind="variant folder")
    return write_file(path, text, kind="variant file")


def run(study_path, out_dir: Path | None = None, n_starts: int | None = None, progress=None,
        write: bool = True) -> dict:
    """Build, multistart-solve and report one study; writes the best design as a variant file (with
    `write` False it is not written: result['pending_files'] = {path: text}, for the caller to write
    together with its own files)."""
    problem = build_problem(study_path)
    if n_starts is not None:
        problem.spec.multistart.starts = n_starts
    zs = starts(problem)
    solutions = []
    for k, z0 in enumerate(zs):
        solutions.append(solve_from(problem, z0, k))
        if progress:
            progress(k + 1, len(zs), solutions[-1])
    optima = distinct_optima(solutions)
    result = {"study": problem.spec.name, "starts": len(zs),
              "statuses": [s.status for s in solutions],
              "optima": [{"objective": s.objective, "design": s.design, "found": n} for s, n in optima]}
    result["envelope_checks"] = [s.check.as_dict() if s.check else None for s in solutions]
    if not write:
        result["pending_files"] = {}
    if not optima:
        # no start passed IPOPT and the envelope check: report the best failure, write no variant
        best = min(solutions, key=lambda s: s.objective)
        result.update(status=best.status, success=False, objective=None, design=best.design,
                      active_constraints=[], constraints=[], variant_file=None,
                      envelope_check=best.check.as_dict() if best.check else None)
        return result
    best = optima[0][0]
    report = constraint_report(problem, best)
    out_dir = Path(out_dir or Path("results") / problem.spec.name)
    if write:
        variant = write_variant(problem, best, out_dir)
    else:
        variant, text = variant_text(problem, best, out_dir)
        result["pending_files"][variant] = text
    result.update(status=best.status, success=True, objective=best.objective, design=best.design,
                  envelope_check=best.check.as_dict(),
                  constraints=report, active_constraints=[r["name"] for r in report if r["active"]],
                  variant_file=str(variant), objective_kind=problem.spec.objective.kind,
                  base_variant=str(problem.base_file), base_design=dict(zip(problem.names, problem.base_values.tolist())))
    return result


def pareto_front(study_path, spec: StudySpec, base_file: Path, fixed: dict | None = None,
                 points: int | None = None) -> list[dict]:
    """Slip/efficiency trade-off by the ε-constraint method: minimise power loss subject to worst |α| ≤ ε,
    ε from the slip optimum's worst |α| to that of the loss optimum, each point warm-started from the last.
    Returns one dict per point: eps, worst_alpha_deg, power_loss_W, design, status, solution."""
    slip = build_problem(study_path, spec, base_file, fixed, objective="worst_alpha")
    loss = build_problem(study_path, spec, base_file, fixed, objective="power_loss")
    front = build_problem(study_path, spec, base_file, fixed, objective="pareto")
    z0 = starts(slip)[0]
    s_slip, s_loss = solve_from(slip, z0), solve_from(loss, z0)
    lo, hi = s_slip.objective, float(slip.start_t(s_loss.z))
    out, prev = [], s_slip
    for k, eps in enumerate(np.linspace(lo, hi, points or spec.pareto.points)):
        sol = solve_from(front, prev.z, k, eps=float(eps))
        worst = float(slip.start_t(sol.z))
        out.append({"index": k, "eps": float(eps), "worst_alpha_deg": worst, "power_loss_W": sol.objective,
                    "design": sol.design, "status": sol.status, "success": sol.success, "solution": sol,
                    "problem": front})
        if sol.success:
            prev = sol
    return out


def knee(front: list[dict]) -> int:
    """Index of the knee: the successful point farthest from the straight line joining the two ends
    (both objectives scaled to [0, 1])."""
    ok = [p for p in front if p["success"]]
    if len(ok) < 3:
        return ok[0]["index"] if ok else 0
    a = np.array([[p["worst_alpha_deg"], p["power_loss_W"]] for p in ok])
    a = (a - a.min(0)) / np.where(np.ptp(a, 0) > 0, np.ptp(a, 0), 1)
    d = np.abs(np.cross(a[-1] - a[0], a - a[0])) / max(np.linalg.norm(a[-1] - a[0]), 1e-12)
    return ok[int(np.argmax(d))]["index"]
