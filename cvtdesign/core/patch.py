"""Each roller's contact patch with the sphere: the Hertz ellipse, Kalker's coefficients, the creep constants of
linear theory and the creep–force curves of the saturating law (core.creep), at a given normal force.

The rolling direction x of a contact is the roller's circumferential direction, so the patch's semi-axis a
lies along it and b along the roller's axle; the curvature sums are A = (1/R + 1/r)/2 along x and
B = (1/R + 1/r_crown)/2 across (core.contact.curvature_sums). Materials combine as Kalker's G and ν and the
Hertz E* (core.contact.contact_material).
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from cvtdesign.core import contact
from cvtdesign.core.creep import creep_forces, spin_force, spin_moment
from cvtdesign.core.layout import Layout, Roller

CURVE_POINTS = 41        # points of each creep–force curve
CURVE_SPAN = 10.0        # the curves run to this many times the creepage whose linear force is μN (|F| ≥ 0.99 μN)


def patch(layout: Layout, roller: Roller, N=None) -> dict:
    """The contact of `roller` with the sphere at normal force N [N] (default: its preload): a, b [m], peak
    pressure p0 [Pa], G [Pa], ν, E* [Pa], Kalker's C11, C22, C23, C33, μ, linear theory's creep constants
    eps_long = 1/(G a b C11), eps_lat = 1/(G a b C22) [1/N], its spin coefficient G (ab)^(3/2) C23 [N·m] and
    spin-moment coefficient G (ab)² C33 [N·m²], and the pivoting lever ℓ [m] (a pivoting patch carries μNℓ).
    Floats, or CasADi expressions when the layout or N is symbolic."""
    sphere = layout.sphere_material
    N = roller.preload if N is None else N
    A, B = contact.curvature_sums(layout.sphere_radius, roller.radius, roller.crown_radius)
    E_star, G, nu = contact.contact_material(roller.material.E, roller.material.nu, sphere.E, sphere.nu)
    a, b, p0, _ = contact.hertz_ellipse(A, B, N, E_star)
    C11, C22, C23, C33 = contact.kalker_coefficients(a / b, nu)
    e_long, e_lat = contact.creep_compliances(G, a, b, C11, C22)
    mu = ca.fmin(roller.material.mu, sphere.mu)
    return {"N": N, "a": a, "b": b, "p0": p0, "G": G, "nu": nu, "E_star": E_star, "C11": C11, "C22": C22,
            "C23": C23, "C33": C33, "mu": mu, "eps_long": e_long, "eps_lat": e_lat,
            "spin_coefficient": contact.spin_force_coefficient(G, a, b, C23),
            "spin_moment_coefficient": contact.spin_moment_coefficient(G, a, b, C33),
            "pivot_lever": contact.pivot_lever(a, b)}


def curves(p: dict) -> dict:
    """Creep–force curves of a patch (numeric), each a list of [creepage, F/(μN)] from zero creepage to full
    slip: longitudinal ξ [-] (Fx), lateral η [-] (Fy) and spin φ [1/m] (Fy); and `spin_moment`, the pure-spin
    moment as [φ, Mz/(μNℓ)] (ℓ the pivoting lever). Forces and moment are those on the sphere's partner,
    counted positive along the creepage (−F of core.creep's convention)."""
    q = {k: float(v) for k, v in p.items()}
    muN = q["mu"] * q["N"]
    span = {"longitudinal": CURVE_SPAN * muN / (q["G"] * q["a"] * q["b"] * q["C11"]),
            "lateral": CURVE_SPAN * muN / (q["G"] * q["a"] * q["b"] * q["C22"]),
            "spin": CURVE_SPAN * muN / q["spin_coefficient"],
            "spin_moment": CURVE_SPAN * muN * q["pivot_lever"] / q["spin_moment_coefficient"]}
    args = (q["N"], q["mu"], q["a"], q["b"], q["G"])
    scale = {"spin_moment": muN * q["pivot_lever"]}
    force = {"longitudinal": lambda s: creep_forces(s, 0.0, *args, q["C11"], q["C22"])[0],
             "lateral": lambda s: creep_forces(0.0, s, *args, q["C11"], q["C22"])[1],
             "spin": lambda s: spin_force(0.0, 0.0, s, *args, q["C23"]),
             "spin_moment": lambda s: spin_moment(0.0, s, *args, q["C23"], q["C33"])}
    return {kind: [[float(s), -float(force[kind](s)) / scale.get(kind, muN)]
                   for s in np.linspace(0.0, span[kind], CURVE_POINTS)] for kind in span}
