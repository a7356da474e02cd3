"""The contact laws: how each contact's slip and tangential force are related in the model (core.model).

A law is one class with one instance in LAWS, chosen by name in one place (`contact_law`). The model calls,
for every contact while it assembles the equations:
 * `constants(layout, roller)`: the patch's constants at its preload (numbers, or CasADi expressions of the
   design);
 * `creep_normal(hooks, roller, N)`: the normal force the law follows and the exponent of ε ∝ N^(−n);
 * `compliance(layout, roller)`: the creep compliance [1/N] at the preload in the roller's own direction (along
   the rolling direction for drive and follower rollers, across it for steering rollers), as calibrated;
 * `rows(layout, hooks, c, s_t, s_a, v_ref, calls)`: a ContactRows (two scaled residual rows, zero when the law holds;
   the traction utilisations for the gross-slip test; the spin moment the patch puts on the sphere about its
   normal; the creep coefficients as the law used them);
 * `load_natives()`: loads into the process the compiled code that a compiled model of the law calls, so that a
   model's library loaded without building the model (core.model.library_model) finds it.
and says, as class attributes, what the rest of the package reads of it:
 * `contains`: the effects of the vocabulary that the law already contains (they are refused as effects);
 * `fitted`: whether the variant gives the law fitted creep constants (contact.creep_drive, creep_steering and
   creep_reference_force) or else calibration factors on its theory (contact.calibration);
 * `rigid_unless_effects`: whether a direction that no effect makes compliant is held rigid;
 * `reference_variant`: the shipped variant that is Kim's CVT written under this law (compare's reference);
 * `spin_error`: the relative error of its spin moment against the exact theory (a half-range), or None where
   the law has no spin moment (a figure made of it, the rolling steering torque, is then not modelled).
Adding a law means adding one class here (docs/adding-a-contact-law.md); nothing outside this module compares
a law's name.

A law that calls a compiled function (a table) does so through `calls` (core.deferred), so the model
differentiates the call once, not once per unknown. Notation as in core.model: s_t, s_a the slip velocity of the sphere over the roller along the rolling direction
t and the axle a [m/s], F_t, F_a the force on the sphere, c a core.effects.ContactState.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from cvtdesign.core.contact import hertz, kalker, surface
from cvtdesign.core.effects import EFFECTS, ContactState, check_names
from cvtdesign.core.layout import Layout, Roller
from cvtdesign.errors import InputError

EPS_RIGID = 1e-9      # [1/N] creep-compliance floor of the directions that are rigid under Kim's law
ROLL_FLOOR = 1e-9     # rolling speed below which creepages are taken at this fraction of the reference speed
ROLL_BLEND = 1e-6     # rolling speed (fraction of the reference speed) within which both rolling senses are blended


@dataclass
class ContactRows:
    """What a law contributes for one contact (module docstring)."""
    rows: list              # two residual rows, scaled to order one
    utilisation: list       # traction utilisations |F|/(μN) of a saturating law (gross slip at SAT_LIMIT)
    spin_moment: object     # moment of the patch's tractions on the sphere about the contact normal [N m]
    slopes: tuple           # small-creepage slopes as used [N per unit ξ, N per unit η, N m per unit φ [1/m]]
    speed: object           # the rolling speed the creepages are taken at [m/s]


def patch_constants(layout: Layout, roller: Roller) -> dict:
    """The Hertz patch of `roller` at its preload P and Kalker's coefficients for it: a, b [m], p0 [Pa], G [Pa],
    ν, E* [Pa], C11, C22, C23, C33 [-], μ [-] and the pivoting lever ℓ [m]. A calibrated roller (roller.creep
    from the materials library) creeps with the combined G and ν of its creep modulus; its Hertz patch keeps
    the nominal modulus."""
    sphere = layout.sphere_material
    A, B = hertz.curvature_sums(layout.sphere_radius, roller.radius, roller.crown_radius)
    E_star, G, nu = hertz.contact_material(roller.material.E, roller.material.nu, sphere.E, sphere.nu)
    a, b, p0, _ = hertz.hertz_ellipse(A, B, roller.preload, E_star)
    if roller.creep.creep_modulus is not None:       # a calibration: the creep law's G and ν at the creep modulus
        _, G, nu = hertz.contact_material(roller.creep.creep_modulus, roller.material.nu, sphere.E, sphere.nu)
    C11, C22, C23, C33 = kalker.kalker_coefficients(a / b, nu)
    return {"a": a, "b": b, "p0": p0, "G": G, "nu": nu, "E_star": E_star, "C11": C11, "C22": C22, "C23": C23,
            "C33": C33, "mu": roller.friction.mu, "lever": hertz.pivot_lever(a, b)}


class KimLaw:
    """Kim et al.'s law ("Causes of microslip in a continuously variable transmission", eqs 19-32): each
    contact creeps linearly, s + c·F = 0, with the compliances the effects contribute (c = ε·V for creep
    constant ε [1/N] at rolling speed V), scaled by their saturation gains; a direction no effect makes
    compliant is rigid (a floor EPS_RIGID·V_ref keeps the statically indeterminate system regular). ε is the
    variant's fitted constant (contact.creep_drive / creep_steering at creep_reference_force), else linear
    Kalker theory's 1/(G a b C11) for drive and 1/(G a b C22) for steering rollers at the preload."""
    name = "kim"
    contains: dict = {}
    fitted = True
    rigid_unless_effects = True
    reference_variant = "existing_kim"
    spin_error = None       # no spin moment at all: the figures that need one are not modelled
    several_roots = False   # inside the envelopes the roots are unique (core.model._solve_from_rest)

    def constants(self, layout: Layout, roller: Roller) -> dict:
        p = patch_constants(layout, roller)
        drive = roller.role != "steering"
        fitted = layout.creep_drive if drive else layout.creep_steering
        theory = 1.0 / (p["G"] * p["a"] * p["b"] * (p["C11"] if drive else p["C22"]))
        n_ref = layout.creep_reference_force if fitted is not None and layout.creep_reference_force is not None \
            else roller.preload
        return {**p, "eps0": theory if fitted is None else fitted, "n_ref": n_ref}

    def creep_normal(self, hooks, roller: Roller, N):
        return hooks.transform("creep_normal", (roller.preload, 2.0 / 3.0), N)

    def load_natives(self):
        """Nothing: the law's equations are all in the model."""

    def compliance(self, layout: Layout, roller: Roller) -> float:
        """The fitted constant moved to the preload (ε ∝ N^(-2/3)), or the theory's."""
        c = self.constants(layout, roller)
        return float(c["eps0"] * (c["n_ref"] / roller.preload) ** (2.0 / 3.0))

    def rows(self, layout: Layout, hooks, c: ContactState, s_t, s_a, v_ref, calls):
        floor = EPS_RIGID * ca.fabs(v_ref)
        terms = hooks.collect("compliance", c)
        ct, ca_ = sum(x[0] for x in terms), sum(x[1] for x in terms)
        sat = []
        for gain, util in hooks.collect("saturation", c):
            ct, ca_ = ct * gain, ca_ * gain
            sat.append(util)
        rows = [(s_t + (ct + floor) * c.Ft) / v_ref, (s_a + (ca_ + floor) * c.Fa) / v_ref]
        return ContactRows(rows, sat, 0.0, (c.V / (ct + floor), c.V / (ca_ + floor), 0.0), c.V)


class KalkerLaw:
    """Hertz + Kalker at every contact, with creep and spin combined as FASTSIM combines them
    (core.contact.surface): the patch at the force-balanced normal force N (a, b ∝ N^(1/3)), the creepages
    normalised by Kalker's coefficients divided by the calibration factor k (contact.calibration × the
    effects' `calibration` hooks), and the force and spin moment read from the creep-force surface.

    Patch frame (Kalker's theory has the material pass through the patch along −x): e_x = σ t, e_y = −σ a,
    e_n = n with σ the sign of Ω·a. The surface is odd in (ξ, η, φ) together, so the force on the sphere is
    F_t = μN f_x(ξ', η', σφ), F_a = −μN f_y(ξ', η', σφ) and its spin moment about n is σ μN a f_M(ξ', η', σφ),
    with ξ' = s_t/V, η' = −s_a/V and φ = Ω·n/V, V the rolling speed R|Ω·a| (held above ROLL_FLOOR·V_ref). A
    contact that does not roll has no rolling direction: it slides, at creepages of order 1e9, where the force
    is the same for either σ, except by the table's resolution near full sliding (which moved α by 1e-7 rad
    between two ways of writing one layout). So within ROLL_BLEND·V_ref of zero rolling speed the law is the
    mean of its values for σ = ±1, exactly symmetric; elsewhere the weight is 0 or 1 to machine precision. The
    rows are the force residuals (F − μN f)/(μP), P the preload."""
    name = "kalker"
    contains = {"normal_force_variation": "the Hertz patch follows the force-balanced N",
                "drive_spin_creep": "spin acts through Kalker's C23 and FASTSIM",
                "traction_saturation": "FASTSIM saturates every contact towards μN"}
    fitted = False
    rigid_unless_effects = False
    reference_variant = "existing"
    spin_error = 0.15       # FASTSIM's spin moment against Kalker's exact theory, at the hardest points
                            # (docs/contact.md): a uniform ±15 % in the intervals (core.uncertainty)
    several_roots = True    # a point may have two roots: each is also solved from rest (core.model)

    def constants(self, layout: Layout, roller: Roller) -> dict:
        p = patch_constants(layout, roller)
        return {**p, "log_ratio": ca.log(p["a"] / p["b"])}

    def load_natives(self):
        """The creep-force surface's library (core.contact.surface), whose functions the model calls."""
        surface.law_functions()

    def creep_normal(self, hooks, roller: Roller, N):
        """N kept above zero on the scale of 1e-3 of the preload P (a patch at N ≤ 0 does not exist; such a
        point is lost contact), smooth for Newton: (N + √(N² + (1e-3 P)²))/2; a and b follow N^(1/3)."""
        return 0.5 * (N + ca.sqrt(N * N + (1e-3 * roller.preload) ** 2)), 0.0

    def compliance(self, layout: Layout, roller: Roller) -> float:
        """Linear theory's 1/(G a b C11) (drive) or 1/(G a b C22) (steering) at the roller's creep modulus (a
        library calibration), times contact.calibration."""
        p, side = patch_constants(layout, roller), "drive" if roller.role != "steering" else "steering"
        e_long, e_lat = kalker.creep_compliances(p["G"], p["a"], p["b"], p["C11"], p["C22"])
        return float((e_long if side == "drive" else e_lat) * layout.calibration[side])

    def rows(self, layout: Layout, hooks, c: ContactState, s_t, s_a, v_ref, calls):
        const = c.constants
        k = layout.calibration["drive" if c.drive else "steering"]
        for factor in hooks.collect("calibration", c):
            k = k * factor
        size = (c.N_creep / c.roller.preload) ** (1.0 / 3.0)
        a, b = const["a"] * size, const["b"] * size
        mu_n = c.mu * c.N_creep
        v = ca.sqrt(c.V ** 2 + (ROLL_FLOOR * v_ref) ** 2)
        g = const["G"] * a * b / (k * mu_n * v)
        z = [surface.compactify(ca.vertcat(g * const["C11"] * s_t, -g * const["C22"] * s_a,
                                           g * ca.sqrt(a * b) * const["C23"] * sigma * c.spin)) for sigma in (1.0, -1.0)]
        w = 0.5 * (1.0 + ca.tanh(layout.sphere_radius * c.roll / (ROLL_BLEND * ca.fabs(v_ref))))   # weight of σ = +1
        f = calls.call(*surface.law_functions(), [*z, const["log_ratio"], w])
        scale = c.mu * c.roller.preload
        rows = [(c.Ft - mu_n * f[0]) / scale, (c.Fa + mu_n * f[1]) / scale]
        gab = const["G"] * a * b / k
        return ContactRows(rows, [ca.sqrt(f[0] ** 2 + f[1] ** 2)], layout.spin_factor * mu_n * a * f[2],
                           (gab * const["C11"], gab * const["C22"], gab * ca.sqrt(a * b) * const["C23"]), v)


LAWS = {law.name: law for law in (KimLaw(), KalkerLaw())}
IDEAL = "kim"           # the ideal CVT: rigid rolling contacts, Kim's law with no effect on
DEFAULT = "kalker"      # a variant's law when it names none: the most complete physics (creep, spin, saturation)


def contact_law(name: str):
    """The law called `name` (what contact.law in a variant file names)."""
    if name not in LAWS:
        raise InputError(f"contact.law: unknown law '{name}' (laws: {', '.join(LAWS)})")
    return LAWS[name]


def check_effects(names, where: str, law: str = IDEAL) -> tuple:
    """The effect names, checked against the vocabulary (core.effects.check_names) and against the law: an
    effect the law already contains is an InputError naming `where`."""
    contained = contact_law(law).contains
    for e in check_names(names, where):
        if e in contained:
            raise InputError(f"{where}: {e} is part of contact.law {law} ({contained[e]}); leave it out")
    return tuple(names)


def candidates(law: str) -> list[str]:
    """The effects that can be added to a model with this contact law (the diagnosis's candidates)."""
    return [e for e in EFFECTS if e not in contact_law(law).contains]
