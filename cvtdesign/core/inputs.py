"""The uncertain physical inputs of a layout's figures, each with its relative standard deviation and where it
comes from, and the model in which they are inputs (core.uncertainty carries them to every figure).

What is uncertain (a relative deviation x of each, the figure's derivative taken at x = 0):
 * the calibration of each role's creep compliance (drive and follower contacts; steering contacts): the scales
   of the two creep effects (core.effects.CALIBRATION; θ, not a design input here), σ from the
   calibration (a library fit, the variant's own constants, or a transferred calibration's wider σ);
 * the preload P(1 + x) of every roller together: σ `preload_std`, 20 % where the variant states none; and
   the preload the calibration's machine ran at (Kim et al. state none; 100 N is this project's assumption),
   σ 20 %. A calibration holds the compliance it was fitted to, so a calibrated creep modulus moves with that
   preload and with its materials' moduli (`_recalibrated`): on the measured machine itself (a variant marked
   `calibration_machine`, at the calibration's preload) the assumption cancels, as it must; on any other
   layout, even at the same nominal preload, its own preload is set when it is built and does not;
 * each material's Young's modulus E(1 + x): σ `youngs_modulus_std`, 25 % where none is stated (a modulus
   read from a Shore A hardness by Gent's relation is good to ±20–30 %);
 * each pair's friction μ(1 + x): uniform over the pair's range (docs/materials.md, 'Friction');
 * the contact law's own error: the spin moment × (1 + x), uniform over ±`spin_error` (FASTSIM against
   Kalker's exact theory: 15 % at the hardest points, docs/contact.md);
 * effect parameters fitted to measurements, with the σ the variant gives (effect_uncertainty).

Each input has a `key`. Inputs of one key are one physical quantity: two variants that name one material,
one pair, one calibration or one law share it, and their figures move together (compare's orderings take
the difference's own interval). A preload is set when a machine is assembled, so each variant's is its own.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import casadi as ca

from cvtdesign.core import basis
from cvtdesign.core.contact.laws import contact_law
from cvtdesign.core.effects import CALIBRATION
from cvtdesign.core.contact.hertz import contact_material
from cvtdesign.core.layout import Layout, Material, Roller
from cvtdesign.core.model import CompiledModel, compile_model

SCALES = {side: f"{effect}.scale" for side, effect in CALIBRATION.items()}


@dataclass(frozen=True)
class Input:
    """One uncertain input: `key` (one physical quantity, shared between layouts that have it), `label` (in a
    budget), `std` the relative 1σ [-] (of a uniform spread: half-width/√3), `assumed` where no file states it,
    `kind` ('calibration', 'effect', 'calibration_preload', 'preload', 'modulus', 'friction', 'spin') and
    `target` (a θ name for calibration and effect inputs; the material's name or the pair for moduli and
    friction; for the calibration's preload, whether it is also this layout's own; None otherwise)."""
    key: str
    label: str
    std: float
    assumed: bool
    kind: str
    target: object = None

    @property
    def in_theta(self) -> bool:
        return self.kind in ("calibration", "effect")


CALIBRATION_PRELOAD_STD = 0.20   # relative 1σ of the preload a calibration's machine ran at (Kim et al. state none)


def calibration_preload(layout: Layout) -> float | None:
    """The normal force [N] the layout's calibrations were fitted at (a library calibration's `preload`, or
    Kim's constants' creep_reference_force), or None where none is stated or they differ."""
    forces = {r.creep.preload for r in layout.rollers if r.creep.kind in ("library", "transferred")}
    if layout.creep_reference_force is not None:
        forces.add(float(layout.creep_reference_force))
    return forces.pop() if len(forces) == 1 and None not in forces else None


def physical_inputs(layout: Layout) -> list[Input]:
    """The design-side inputs of `layout` (module docstring), in the order of the uncertain model's design
    vector: the preload of the calibration's machine (shared by that machine itself, `calibration_machine` at
    that preload) and, on any other layout, its own preload; each material's modulus, each pair's friction,
    the law's spin moment."""
    ref = calibration_preload(layout)
    same = ref is not None and layout.calibration_machine and \
        all(isinstance(r.preload, float) and abs(r.preload - ref) < 1e-9 * ref for r in layout.rollers)
    out = []
    if ref is not None:
        out.append(Input("preload of the calibration's machine", f"preload (the calibration's machine, {ref:g} N "
                         "assumed" + (", and this one's" if same else "") + ")", CALIBRATION_PRELOAD_STD, True,
                         "calibration_preload", same))
    if not same:
        out.append(Input(f"preload of {layout.name}", "preload", layout.preload_std, layout.preload_std_assumed,
                         "preload"))
    materials = {r.material.name: r.material for r in layout.rollers} | \
        {layout.sphere_material.name: layout.sphere_material}
    out += [Input(f"modulus {n}", f"modulus {n}", m.E_std, m.E_std_assumed, "modulus", n)
            for n, m in sorted(materials.items())]
    pairs = {(r.material.name, layout.sphere_material.name): r.friction for r in layout.rollers}
    for (a, b), f in sorted(pairs.items()):
        if f.high > f.low:
            out.append(Input(f"friction {a} on {b}", f"friction {a} on {b}",
                             (f.high - f.low) / (2 * math.sqrt(3) * f.mu), False, "friction", (a, b)))
    spin = contact_law(layout.contact_law).spin_error
    if spin:
        out.append(Input(f"spin moment ({layout.contact_law})", f"spin moment ({layout.contact_law} law's own error)",
                         spin / math.sqrt(3), False, "spin"))
    return out


def theta_inputs(layout: Layout, param_names: list) -> list[Input]:
    """The θ-side inputs: each role's calibration (one input per calibration source, so that two roles
    resting on one calibration move together) and the fitted effect parameters with a stated σ; [] for a role
    whose σ is unknown (theory only: core.basis)."""
    cal = basis.calibration(layout)
    out = []
    for role in basis.ROLES:
        mine = [r for r in layout.rollers if basis.role_of(r) == role]
        if not mine or cal["std"][role] is None or SCALES[role] not in param_names:
            continue
        source = "; ".join(sorted({r.creep.source for r in mine}))
        kinds = {r.creep.kind for r in mine}
        out.append(Input(f"calibration: {source}", f"calibration ({role}" + (", transferred)" if "transferred" in kinds
                                                                            else ")"),
                         cal["std"][role], False, "calibration", SCALES[role]))
    for e, params in layout.effect_uncertainty.items():
        for p, sd in params.items():
            if f"{e}.{p}" in param_names:
                out.append(Input(f"{layout.name}: {e}.{p}", f"{e}.{p} (fitted)", sd, False, "effect", f"{e}.{p}"))
    return out


def deviated(layout: Layout, inputs: list[Input], x) -> Layout:
    """`layout` with each physical input's relative deviation x[j] (floats or CasADi symbols) applied."""
    rollers, sphere, spin, ref = list(layout.rollers), layout.sphere_material, layout.spin_factor, 1.0
    for j, inp in enumerate(inputs):
        if inp.kind == "calibration_preload":
            ref = 1 + x[j]
        if inp.kind == "preload" or (inp.kind == "calibration_preload" and inp.target):
            rollers = [replace(r, preload=r.preload * (1 + x[j])) for r in rollers]
        elif inp.kind == "modulus":
            rollers = [replace(r, material=replace(r.material, E=r.material.E * (1 + x[j])))
                       if r.material.name == inp.target else r for r in rollers]
            if sphere.name == inp.target:
                sphere = replace(sphere, E=sphere.E * (1 + x[j]))
        elif inp.kind == "friction":
            rollers = [replace(r, friction=replace(r.friction, mu=r.friction.mu * (1 + x[j])))
                       if (r.material.name, layout.sphere_material.name) == inp.target else r for r in rollers]
        elif inp.kind == "spin":
            spin = spin * (1 + x[j])
    rollers = [_recalibrated(r, d, layout.sphere_material, sphere, ref) for r, d in zip(layout.rollers, rollers)]
    built = replace(layout, rollers=tuple(rollers), sphere_material=sphere, spin_factor=spin)
    fitted = layout.creep_drive is not None or layout.creep_steering is not None
    if fitted and layout.creep_reference_force is not None:      # Kim's constants hold at his machine's preload
        built = replace(built, creep_reference_force=layout.creep_reference_force * ref)
    return built


def _recalibrated(drawn: Roller, r: Roller, sphere0: Material, sphere, ref):
    """Roller r (drawn's deviated form) with its calibrated creep modulus as the measurement makes it: the fit
    holds the measured compliance, ∝ E*^(2/3) P^(−2/3) / E_c (Hertz + Kalker, the sphere far stiffer), at the
    calibration machine's preload P·ref, so E_c follows E*'s deviation^(2/3) and ref^(−2/3); a transferred one
    follows the roller's own modulus (E_c = E/ratio) and ref^(−2/3)."""
    c = r.creep
    if c.creep_modulus is None:
        return r
    if c.kind == "transferred":
        factor = r.material.E / drawn.material.E
    else:
        E0, _, _ = contact_material(drawn.material.E, drawn.material.nu, sphere0.E, sphere0.nu)
        E1, _, _ = contact_material(r.material.E, r.material.nu, sphere.E, sphere.nu)
        factor = (E1 / E0) ** (2.0 / 3.0)
    return replace(r, creep=replace(c, creep_modulus=c.creep_modulus * factor * ref ** (-2.0 / 3.0)))


def uncertain_model(layout: Layout, effects=None) -> CompiledModel:
    """The model of `layout` whose design vector is the relative deviations of its physical inputs
    (physical_inputs, in that order): at design 0 it is the nominal model, and its exact derivatives in the
    design vector are the figures' sensitivities to those inputs."""
    inputs = physical_inputs(layout)
    x = ca.SX.sym("x", len(inputs))
    return compile_model(layout, effects, design=x, as_built=deviated(layout, inputs, [x[j] for j in range(len(inputs))]))


def model_inputs(model: CompiledModel) -> list[Input]:
    """Every uncertain input of a model built by `uncertain_model`: its θ inputs, then its design inputs."""
    design = physical_inputs(model.layout) if model.design.numel() else []
    return theta_inputs(model.layout, model.param_names) + design
