"""The two contact laws the package ships: Kim et al.'s fitted linear creep (`KimLaw`) and Hertz + Kalker with
FASTSIM at every contact (`KalkerLaw`). Each is one ContactLaw subclass (core.contact.base, which describes the
interface and registers each law in LAWS as its class is defined); this module also holds what the package asks
of the laws as a whole: `contact_law`, the `IDEAL` and `DEFAULT` laws' names, `check_effects` and `candidates`.
A new law is one subclass of ContactLaw, in this module or its own (docs/adding-a-contact-law.md); nothing
outside a law's own class names it.

A law that calls a compiled function (a table) does so through `calls` (core.deferred), so the model
differentiates the call once, not once per unknown. Notation as in core.model: s_t, s_a the slip velocity of the sphere over the roller along the rolling direction
t and the axle a [m/s], F_t, F_a the force on the sphere, c a core.effects.ContactState.
"""
from __future__ import annotations

import casadi as ca

from cvtdesign.core.contact import surface
from cvtdesign.core.contact.base import (LAWS, ContactLaw, ContactRows, contact_law, names_where, patch_constants, side,
                                         the_law)
from cvtdesign.core.effects import EFFECTS, ContactState, check_names
from cvtdesign.core.layout import Layout, Roller
from cvtdesign.errors import InputError

__all__ = ["LAWS", "ContactLaw", "ContactRows", "KimLaw", "KalkerLaw", "IDEAL", "DEFAULT", "contact_law", "patch_constants",
           "check_effects", "candidates", "names_where", "EPS_RIGID"]

EPS_RIGID = 1e-9      # [1/N] creep-compliance floor of the directions that are rigid under Kim's law
ROLL_FLOOR = 1e-9     # rolling speed below which creepages are taken at this fraction of the reference speed
ROLL_BLEND = 1e-6     # rolling speed (fraction of the reference speed) within which both rolling senses are blended


class KimLaw(ContactLaw):
    """Kim et al.'s law ("Causes of microslip in a continuously variable transmission", eqs 19-32): each
    contact creeps linearly, s + c·F = 0, with the compliances the effects contribute (c = ε·V for creep
    constant ε [1/N] at rolling speed V), scaled by their saturation gains; a direction no effect makes
    compliant is rigid (a floor EPS_RIGID·V_ref keeps the statically indeterminate system regular). ε is the
    variant's fitted constant (contact.creep_drive / creep_steering at creep_reference_force), else linear
    Kalker theory's 1/(G a b C11) for drive and 1/(G a b C22) for steering rollers at the preload."""
    name = "kim"
    title = "Kim et al.'s fitted linear creep constants"
    fitted = True
    rigid_unless_effects = True
    reference_variant = "existing_kim"
    spin_error = None       # no spin moment at all: the figures that need one are not modelled
    several_roots = False   # inside the envelopes the roots are unique (core.model._solve_from_rest)
    ideal = True            # the ideal CVT: rigid rolling contacts, this law with no effect on

    def constants(self, layout: Layout, roller: Roller) -> dict:
        p = patch_constants(layout, roller)
        drive = side(roller) == "drive"
        fitted = layout.creep_drive if drive else layout.creep_steering
        theory = 1.0 / (p["G"] * p["a"] * p["b"] * (p["C11"] if drive else p["C22"]))
        n_ref = layout.creep_reference_force if fitted is not None and layout.creep_reference_force is not None \
            else roller.preload
        return {**p, "eps0": theory if fitted is None else fitted, "n_ref": n_ref}

    def creep_normal(self, hooks, roller: Roller, N):
        return hooks.transform("creep_normal", (roller.preload, 2.0 / 3.0), N)

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
        return ContactRows(rows, sat, 0.0, (c.V / (ct + floor), c.V / (ca_ + floor), 0.0), c.V,
                           (v_ref / (ct + floor), v_ref / (ca_ + floor)))


class KalkerLaw(ContactLaw):
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
    title = "Hertz + Kalker with FASTSIM's creep, spin and saturation at every contact"
    contains = {"normal_force_variation": "the Hertz patch follows the force-balanced N",
                "drive_spin_creep": "spin acts through Kalker's C23 and FASTSIM",
                "traction_saturation": "FASTSIM saturates every contact towards μN"}
    fitted = False
    rigid_unless_effects = False
    reference_variant = "existing"
    spin_error = 0.15       # FASTSIM's spin moment against Kalker's exact theory, at the hardest points
                            # (docs/contact.md): a uniform ±15 % in the intervals (core.uncertainty)
    several_roots = True    # a point may have two roots: each is also solved from rest (core.model)
    default = True          # a variant's law when it names none: the most complete physics (creep, spin, saturation)

    def constants(self, layout: Layout, roller: Roller) -> dict:
        p = patch_constants(layout, roller)
        return {**p, "log_ratio": ca.log(p["a"] / p["b"])}

    def load_natives(self):
        """The creep-force surface's library (core.contact.surface), whose functions the model calls."""
        surface.law_functions()

    def rows(self, layout: Layout, hooks, c: ContactState, s_t, s_a, v_ref, calls):
        const = c.constants
        k = layout.calibration[side(c.roller)]
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
                           (gab * const["C11"], gab * const["C22"], gab * ca.sqrt(a * b) * const["C23"]), v,
                           (scale, scale))


IDEAL = the_law("ideal")        # the ideal CVT's law: rigid rolling contacts with no effect on
DEFAULT = the_law("default")    # a variant's law when it names none


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
