"""The interface every contact law implements: `ContactLaw`, the base class, and `LAWS`, the register of laws.

A law says how each contact's slip and tangential force are related in the model (core.model). It is one
subclass of ContactLaw with a `name`; defining the class registers one instance of it in LAWS under that name,
so a law is one class in one file (docs/adding-a-contact-law.md). The model calls, for every contact while it
assembles the equations:
 * `constants(layout, roller)`: the patch's constants at its preload (numbers, or CasADi expressions of the
   design); the base gives the Hertz patch and Kalker's coefficients (`patch_constants`);
 * `creep_normal(hooks, roller, N)`: the normal force the law follows and the exponent n of ε ∝ N^(−n); the
   base follows the force-balanced N, kept above zero (a patch at N ≤ 0 does not exist), with n = 0;
 * `compliance(layout, roller)`: the creep compliance [1/N] at the preload in the roller's own direction (along
   the rolling direction for drive and follower rollers, across it for steering rollers), as calibrated; the
   base gives linear theory's 1/(G a b C11) or 1/(G a b C22) times the variant's calibration factor;
 * `rows(layout, hooks, c, s_t, s_a, v_ref, calls)`: a ContactRows (two scaled residual rows, zero when the law
   holds; the traction utilisations for the gross-slip test; the spin moment the patch puts on the sphere about
   its normal; the creep coefficients as the law used them; the force each row stands for at fixed slip,
   with which the dynamic model lets the force relax to the law); every law writes its own;
 * `load_natives()`: loads into the process the compiled code that a compiled model of the law calls, so that a
   model's library loaded without building the model (core.model.library_model) finds it; the base loads none.
and says, as class attributes, what the rest of the package reads of it (no module compares a law's name):
 * `name`: what a variant's contact.law names; `title`: how messages and the reference describe it;
 * `contains`: the effects of the vocabulary that the law already contains (they are refused as effects);
 * `fitted`: whether the variant gives the law fitted creep constants (contact.creep_drive, creep_steering and
   creep_reference_force) or else calibration factors on its theory (contact.calibration);
 * `rigid_unless_effects`: whether a direction that no effect makes compliant is held rigid;
 * `reference_variant`: the shipped variant that is Kim et al.'s CVT written under this law (compare's
   reference);
 * `spin_error`: the relative error of its spin moment against the exact theory (a half-range), or None where
   the law has no spin moment (a figure made of it, the rolling steering torque, is then not modelled);
 * `several_roots`: whether a point may have two roots (each point is then also solved from rest);
 * `ideal`: the law of the ideal CVT (rigid rolling contacts with no effect on); one law says so;
 * `default`: a variant's law when it names none; one law says so.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from cvtdesign.core.contact import hertz, kalker
from cvtdesign.core.layout import Layout, Roller
from cvtdesign.errors import InputError

LAWS: dict = {}         # name → the law's one instance, filled as each ContactLaw subclass is defined


@dataclass
class ContactRows:
    """What a law contributes for one contact (module docstring)."""
    rows: list              # two residual rows, scaled to order one
    utilisation: list       # traction utilisations |F|/(μN) of a saturating law (gross slip at SAT_LIMIT)
    spin_moment: object     # moment of the patch's tractions on the sphere about the contact normal [N m]
    slopes: tuple           # small-creepage slopes as used [N per unit ξ, N per unit η, N m per unit φ [1/m]]
    speed: object           # the rolling speed the creepages are taken at [m/s]
    force_per_row: tuple = None   # (∂ρ_t/∂F_t)⁻¹, (∂ρ_a/∂F_a)⁻¹ [N] at fixed slip: the force a unit of each row
                                  # stands for, by which the dynamic model relaxes F to the law (core.dynamics)


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


def side(roller: Roller) -> str:
    """'drive' or 'steering': the side of the variant's constants a roller takes (followers creep as drives)."""
    return "steering" if roller.role == "steering" else "drive"


class ContactLaw:
    """The base of every contact law (module docstring). A subclass sets `name` and `title` and writes `rows`;
    the other methods have the defaults described there."""
    name: str = ""
    title: str = ""
    contains: dict = {}
    fitted = False
    rigid_unless_effects = False
    reference_variant = "existing"
    spin_error = None
    several_roots = False
    ideal = False
    default = False

    def __init_subclass__(cls, **kwargs):
        """Registers the law under its name (a subclass without a name is a base of others, not a law)."""
        super().__init_subclass__(**kwargs)
        if cls.__dict__.get("name"):
            LAWS[cls.name] = cls()

    def constants(self, layout: Layout, roller: Roller) -> dict:
        """The Hertz patch and Kalker's coefficients at the preload (`patch_constants`)."""
        return patch_constants(layout, roller)

    def creep_normal(self, hooks, roller: Roller, N):
        """N kept above zero on the scale of 1e-3 of the preload P (a patch at N ≤ 0 does not exist; such a
        point is lost contact), smooth for Newton: (N + √(N² + (1e-3 P)²))/2, with n = 0."""
        return 0.5 * (N + ca.sqrt(N * N + (1e-3 * roller.preload) ** 2)), 0.0

    def compliance(self, layout: Layout, roller: Roller) -> float:
        """Linear theory's 1/(G a b C11) (drive) or 1/(G a b C22) (steering) at the roller's creep modulus (a
        library calibration), times the variant's calibration factor of the roller's side."""
        p = patch_constants(layout, roller)
        e_long, e_lat = kalker.creep_compliances(p["G"], p["a"], p["b"], p["C11"], p["C22"])
        return float((e_long if side(roller) == "drive" else e_lat) * layout.calibration[side(roller)])

    def rows(self, layout: Layout, hooks, c, s_t, s_a, v_ref, calls) -> ContactRows:
        """The law's residual rows at one contact (module docstring): every law writes its own."""
        raise NotImplementedError(f"contact law {self.name}: rows")

    def load_natives(self):
        """Nothing: the law's equations are all in the model."""


def contact_law(name: str) -> ContactLaw:
    """The law called `name` (what contact.law in a variant file names)."""
    if name not in LAWS:
        raise InputError(f"contact.law: unknown law '{name}' (laws: {', '.join(LAWS)})")
    return LAWS[name]


def names_where(**flags) -> list[str]:
    """The names of the laws whose class attributes equal `flags` (names_where(fitted=True)), for messages that
    say which laws a field applies to."""
    return [n for n, law in LAWS.items() if all(getattr(law, k) == v for k, v in flags.items())]


def the_law(flag: str) -> str:
    """The name of the one law whose class attribute `flag` ('ideal' or 'default') is true."""
    names = [n for n, law in LAWS.items() if getattr(law, flag)]
    assert len(names) == 1, f"exactly one contact law is the {flag} one, got {names}"
    return names[0]
