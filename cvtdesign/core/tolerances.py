"""Toleranced dimensions and the machine as built: a layout whose rollers are off their drawing by deviations
that are CasADi symbols, so that one compiled model serves every sample of a tolerance study and gives the
figures' exact derivatives in the deviations (design.tolerance).

A dimension is one deviation x of one roller, or of several together (`shared`), drawn from a normal
distribution (σ) or a uniform one (±half-width). What x does to a roller (n its contact normal, a its axle,
t = n × a its rolling direction, R the sphere's radius; every direction stays unit, and the axle ⊥ n):
 * axle [rad]: the axle turned about n by x (a misaligned axle, skewed in the tangent plane at the contact);
 * contact [m]: the roller moved over the sphere by x along t (`along: rolling`) or along a (`along: axle`),
   its pose (n and a) turned about the sphere centre by x/R;
 * radius [m]: the rolling radius r + x (the crown radius stays as drawn);
 * preload [-]: the preload P·(1 + x);
 * fork [rad]: every roller of the fork turned about the fork's axis by x: the fork's own angle off by x
   (a fork angle offset, whatever its gear ratio in the linkage).
Rotations about a roller's own normal, axle or rolling direction commute with the others to first order, and
exactly with one another about the same axis, so the order in which dimensions apply does not matter to
first order.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from cvtdesign.core.geometry import rotate
from cvtdesign.core.kinematics import vec
from cvtdesign.core.layout import Layout, Roller
from cvtdesign.errors import InputError

KINDS = {"axle": "angle", "contact": "length", "radius": "length", "preload": "dimensionless", "fork": "angle"}
DIRECTIONS = ("axle", "contact", "fork")       # the dimensions that turn a roller's contact or axle


@dataclass(frozen=True)
class Dimension:
    """One toleranced dimension: `kind` (KINDS), the rollers it moves (a fork's: every roller on it), `along`
    ('rolling' or 'axle', for a contact), its distribution ('normal': `size` is σ; 'uniform': `size` is the
    half-width) in SI (preload: a fraction), its label and the index of the tolerances file's entry."""
    label: str
    kind: str
    rollers: tuple[str, ...]
    distribution: str
    size: float
    entry: int
    along: str | None = None

    @property
    def std(self) -> float:
        """Standard deviation of the deviation [SI]: σ, or half-width/√3 for a uniform distribution."""
        return self.size if self.distribution == "normal" else self.size / math.sqrt(3.0)


def draw(dims, rng: np.random.Generator, n: int) -> np.ndarray:
    """n samples of the deviations, (n, len(dims)) [SI], column j from dims[j]'s distribution, in order."""
    cols = [rng.normal(0.0, d.size, n) if d.distribution == "normal" else rng.uniform(-d.size, d.size, n)
            for d in dims]
    return np.column_stack(cols) if cols else np.zeros((n, 0))


def as_built(layout: Layout, dims, x) -> Layout:
    """The layout with deviation x[j] (floats or CasADi symbols) of each dimension dims[j] applied (module
    docstring). Under a law with fitted creep constants a fitted constant holds at the drawing's preloads, so
    a preload off its drawing creeps as ε ∝ N^(−2/3) says: the layout's creep reference force is pinned to the
    drawn preload (which must then be one value; otherwise contact.creep_reference_force must say where ε holds)."""
    rollers = {r.name: r for r in layout.rollers}
    for j, d in enumerate(dims):
        for name in d.rollers:
            rollers[name] = _deviate(rollers[name], d, x[j], layout.sphere_radius)
    built = replace(layout, rollers=tuple(rollers[r.name] for r in layout.rollers))
    fitted = layout.creep_drive is not None or layout.creep_steering is not None   # a law with fitted constants
    if fitted and layout.creep_reference_force is None and any(d.kind == "preload" for d in dims):
        drawn = {float(r.preload) for r in layout.rollers}
        if len(drawn) > 1:
            raise InputError(f"{layout.file}: contact.creep_reference_force: a preload tolerance under law "
                             f"{layout.contact_law} needs the force at which its fitted creep constants hold (the "
                             "rollers' preloads differ); expected it given")
        built = replace(built, creep_reference_force=drawn.pop())
    return built


def _deviate(r: Roller, d: Dimension, x, R) -> Roller:
    """Roller r with dimension d off by x (module docstring)."""
    n, a = vec(r.normal), vec(r.axle)
    if d.kind == "axle":
        return replace(r, axle=rotate(a, n, x))
    if d.kind == "contact":       # about a by −x/R moves n along +t; about t by +x/R moves it along +a
        axis, angle = (a, -x / R) if d.along == "rolling" else (ca.cross(n, a), x / R)
        return replace(r, normal=rotate(n, axis, angle), axle=rotate(a, axis, angle))
    if d.kind == "radius":
        return replace(r, radius=r.radius + x)
    if d.kind == "preload":
        return replace(r, preload=r.preload * (1 + x))
    k = vec(r.fork_axis)
    return replace(r, normal=rotate(n, k, x), axle=rotate(a, k, x))
