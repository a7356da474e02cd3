"""Each roller's contact patch with the sphere: the Hertz ellipse, Kalker's coefficients, the creep constants of
linear theory, and the creep–force curves of FASTSIM's creep-force surface (core.contact.surface), at a given
normal force.

The rolling direction x of a contact is the roller's circumferential direction, so the patch's semi-axis a
lies along it and b along the roller's axle; the curvature sums are A = (1/R + 1/r)/2 along x and
B = (1/R + 1/r_crown)/2 across (core.contact.hertz.curvature_sums). Materials combine as Kalker's G and ν and
the Hertz E* (core.contact.hertz.contact_material).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from cvtdesign.core.contact import kalker, surface
from cvtdesign.core.contact.base import patch_constants
from cvtdesign.core.contact.laws import contact_law
from cvtdesign.core.layout import CreepSource, Layout, Roller

CURVE_POINTS = 41        # points of each creep–force curve
CURVE_SPAN = 10.0        # the curves run to this many times the creepage whose linear force is μN


def patch(layout: Layout, roller: Roller, N=None) -> dict:
    """The contact of `roller` with the sphere at normal force N [N] (default: its preload): a, b [m], peak
    pressure p0 [Pa], G [Pa], ν, E* [Pa], Kalker's C11, C22, C23, C33, μ, linear theory's creep constants
    eps_long = 1/(G a b C11), eps_lat = 1/(G a b C22) [1/N], its spin coefficient G (ab)^(3/2) C23 [N·m] and
    spin-moment coefficient G (ab)² C33 [N·m²], and the pivoting lever ℓ [m] (a pivoting patch carries μNℓ).
    Floats, or CasADi expressions when the layout or N is symbolic."""
    N = roller.preload if N is None else N
    p = patch_constants(layout, dataclasses.replace(roller, preload=N))
    G, a, b = p["G"], p["a"], p["b"]
    e_long, e_lat = kalker.creep_compliances(G, a, b, p["C11"], p["C22"])
    return {"N": N, **{k: v for k, v in p.items() if k != "lever"}, "eps_long": e_long, "eps_lat": e_lat,
            "spin_coefficient": kalker.spin_force_coefficient(G, a, b, p["C23"]),
            "spin_moment_coefficient": kalker.spin_moment_coefficient(G, a, b, p["C33"]),
            "pivot_lever": p["lever"]}


def theory_patch(layout: Layout, roller: Roller, N=None) -> dict:
    """`patch` by Hertz and Kalker alone: the nominal moduli, whatever calibration the roller has."""
    return patch(layout, dataclasses.replace(roller, creep=CreepSource("theory", "theory only")), N)


def calibrated_compliance(layout: Layout, roller: Roller) -> float:
    """The creep compliance [1/N] the layout's contact law gives `roller` at its preload, in the roller's own
    direction (core.contact.laws: each law's `compliance`)."""
    return contact_law(layout.contact_law).compliance(layout, roller)


def creep_modulus_for(layout: Layout, roller: Roller, compliance: float) -> float:
    """The creep modulus [Pa] (core.layout.CreepSource) with which Hertz + Kalker give `roller` the creep
    compliance [1/N] at its preload, in its own direction (as calibrated_compliance): the Hertz patch at the
    nominal moduli, the creep law's G and ν at this modulus (1-D root; ε ∝ 1/G to within ν's change and the
    sphere's compliance)."""
    drive = roller.role != "steering"

    def eps(E):
        creep = CreepSource("library", "", None, E)
        p = patch(layout, dataclasses.replace(roller, creep=creep))
        return float(p["eps_long"] if drive else p["eps_lat"])
    # ε ∝ 1/G(E), G(E) ≈ E for a roller far softer than the sphere: the secant in log E from E and 2E
    # converges in a few steps (ln ε is nearly linear in ln E)
    x0, x1 = np.log(roller.material.E), np.log(2 * roller.material.E)
    f0, f1 = np.log(eps(np.exp(x0)) / compliance), np.log(eps(np.exp(x1)) / compliance)
    for _ in range(50):
        if abs(f1) < 1e-13 or f1 == f0:
            break
        x0, x1, f0 = x1, x1 - f1 * (x1 - x0) / (f1 - f0), f1
        f1 = np.log(eps(np.exp(x1)) / compliance)
    return float(np.exp(x1))


def forces(p: dict, xi, eta, phi) -> np.ndarray:
    """(Fx, Fy [N], Mz [N m]) on the sphere, in the patch frame, of a numeric patch `p` at creepages ξ, η [-] and
    spin φ [1/m] (arrays), by the creep-force surface with no calibration."""
    q = {k: float(v) for k, v in p.items()}
    mu_n, gab = q["mu"] * q["N"], q["G"] * q["a"] * q["b"]
    c = np.stack(np.broadcast_arrays(*(np.asarray(v, float) for v in (gab * q["C11"] * xi, gab * q["C22"] * eta,
                                                                        gab * np.sqrt(q["a"] * q["b"]) * q["C23"] * phi)))) / mu_n
    f = surface.evaluate(surface.compactify(c.reshape(3, -1)), q["a"] / q["b"]).reshape(c.shape)
    return f * np.array([mu_n, mu_n, mu_n * q["a"]]).reshape((3,) + (1,) * (c.ndim - 1))


def curves(p: dict) -> dict:
    """Creep–force curves of a patch (numeric), each a list of [creepage, F/(μN)] from zero creepage to full
    slip: longitudinal ξ [-] (Fx), lateral η [-] (Fy) and spin φ [1/m] (Fy); and `spin_moment`, the pure-spin
    moment as [φ, Mz/(μNℓ)] (ℓ the pivoting lever). Forces and moment are those on the sphere's partner,
    counted positive along the creepage (−F of Kalker's convention)."""
    q = {k: float(v) for k, v in p.items()}
    mu_n = q["mu"] * q["N"]
    span = {"longitudinal": CURVE_SPAN * mu_n / (q["G"] * q["a"] * q["b"] * q["C11"]),
            "lateral": CURVE_SPAN * mu_n / (q["G"] * q["a"] * q["b"] * q["C22"]),
            "spin": CURVE_SPAN * mu_n / q["spin_coefficient"]}
    span["spin_moment"] = span["spin"]
    pick = {"longitudinal": (0, 0), "lateral": (1, 1), "spin": (2, 1), "spin_moment": (2, 2)}
    scale = {"spin_moment": mu_n * q["pivot_lever"]}
    out = {}
    for kind, (creepage, component) in pick.items():
        s = np.linspace(0.0, span[kind], CURVE_POINTS)
        args = [s if i == creepage else 0.0 for i in range(3)]
        f = -forces(q, *args)[component] / scale.get(kind, mu_n)
        out[kind] = [[float(a), float(b)] for a, b in zip(s, f)]
    return out
