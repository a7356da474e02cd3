"""The tolerances file of `cvtdesign tolerance`: which dimensions of a variant are toleranced, and how.

Each entry of `tolerances` names a dimension (core.tolerances: axle, contact, radius, preload, fork), the
rollers it applies to (names, a role, or all; for a fork, the forks that carry them) and a distribution,
`normal: σ` or `uniform: half-width` (±), in the dimension's unit: an angle ('0.1 deg') for axle and fork, a
length ('0.2 mm') for contact and radius, a fraction ('10 %') for preload. Every roller (or fork) named gets
its own independent deviation, unless `shared: true` gives them one together. docs/tolerances.md has the
format with an example (studies/box_tolerances.yaml).

Every problem is one InputError line naming the file and the field (exit status 2).
"""
from __future__ import annotations

import math
from typing import Literal, Union

from pydantic import StrictBool, StrictInt

from cvtdesign.core.layout import Layout
from cvtdesign.core.tolerances import KINDS, Dimension
from cvtdesign.errors import InputError, suggest
from cvtdesign.io.schema import Name, Num, Strict, spec_field
from cvtdesign.io.units import check_range, to_si
from cvtdesign.io.yaml_file import read_spec

ROLES = ("drive", "follower", "steering")
# plausible size of a deviation (σ or half-width), SI: (what, upper bound, the unit a plain number probably meant)
PLAUSIBLE = {"angle": ("angle tolerance", math.radians(5.0), "deg"), "length": ("length tolerance", 5e-3, "mm"),
             "dimensionless": ("preload tolerance", 0.5, "%")}
WORDS = {"axle": "axle of", "contact": "contact of", "radius": "radius of", "preload": "preload of",
         "fork": "fork of"}


class ToleranceSpec(Strict):
    """One toleranced dimension, for every roller (or fork) it names."""
    dimension: Literal[tuple(KINDS)] = spec_field(
        "axle: the axle turned about its contact normal (angle); contact: the roller moved over the sphere "
        "(length, `along` says which way); radius: the rolling radius (length); preload: the preload (a "
        "fraction, '10 %'); fork: the fork turned off its angle (angle)")
    rollers: Union[str, list[str]] = spec_field(
        "the rollers: a list of names, one name, a role (drive, follower, steering) or all; for a fork, the "
        "forks that carry these rollers", "all")
    along: Literal["rolling", "axle"] | None = spec_field(
        "contact only: rolling (along the roller's rolling direction n × a) or axle (along its axle)", None)
    normal: Num | None = spec_field("a normal distribution: its standard deviation σ, in the dimension's unit", None)
    uniform: Num | None = spec_field("a uniform distribution: its half-width (the deviation lies within ±it), in "
                                     "the dimension's unit", None)
    shared: StrictBool = spec_field("true: one deviation shared by every roller (or fork) named; false: each its "
                                    "own, independent", False)


class TolerancesSpec(Strict):
    """A tolerances file."""
    name: Name = spec_field("the tolerance set's name (letters, digits, '_', '.', '+', '-')")
    description: str = spec_field("what the tolerances are (free text)", "")
    seed: StrictInt = spec_field("seed of the random draws (the same seed draws the same samples)", 0)
    tolerances: list[ToleranceSpec] = spec_field("the toleranced dimensions; each: dimension, rollers, along, "
                                                  "normal or uniform, shared")


def load_tolerances(path, layout: Layout) -> tuple[TolerancesSpec, tuple[Dimension, ...]]:
    """Read a tolerances file and resolve it against the variant's layout: (spec, its dimensions in SI)."""
    where = str(path)
    spec = read_spec(path, TolerancesSpec, "name, tolerances")
    if not spec.tolerances:
        raise InputError(f"{where}: tolerances: empty; expected at least one toleranced dimension")
    if not 0 <= spec.seed < 2 ** 32:
        raise InputError(f"{where}: seed: expected an integer from 0 to 2^32 − 1, got {spec.seed}")
    dims, seen = [], {}
    for i, t in enumerate(spec.tolerances):
        for d in _dimensions(t, i, f"{where}: tolerances.{i}", layout):
            if d.label in seen:
                raise InputError(f"{where}: tolerances.{i}: the {d.label} is already toleranced by "
                                 f"tolerances.{seen[d.label]}; expected each dimension once")
            seen[d.label] = i
            dims.append(d)
    return spec, tuple(dims)


def _dimensions(t: ToleranceSpec, i: int, where: str, layout: Layout) -> list[Dimension]:
    """The dimensions of one entry: one per roller (per fork), or one shared."""
    if (t.normal is None) == (t.uniform is None):
        raise InputError(f"{where}: expected exactly one distribution, normal: σ or uniform: half-width")
    if (t.dimension == "contact") != (t.along is not None):
        raise InputError(f"{where}.along: " + ("missing; a contact moves along rolling or along axle"
                                               if t.dimension == "contact" else "applies to dimension contact only"))
    distribution = "normal" if t.normal is not None else "uniform"
    size = _size(t.normal if t.normal is not None else t.uniform, KINDS[t.dimension], f"{where}.{distribution}")
    groups = _forks(t, where, layout) if t.dimension == "fork" else [(n,) for n in _rollers(t, where, layout)]
    if t.shared:
        groups = [tuple(n for g in groups for n in g)]
    side = {"rolling": " (along rolling)", "axle": " (along axle)", None: ""}[t.along]
    shared = " (shared)" if t.shared and len(groups[0]) > 1 else ""
    return [Dimension(f"{WORDS[t.dimension]} {'+'.join(g)}{side}{shared}", t.dimension, g, distribution, size, i,
                      t.along) for g in groups]


def _size(raw, kind: str, where: str) -> float:
    """The distribution's σ or half-width in SI, positive and plausible (PLAUSIBLE)."""
    value = to_si(raw, kind, where)
    what, hi, guess = PLAUSIBLE[kind]
    if not value > 0:
        raise InputError(f"{where}: expected a positive {what}, got {raw}")
    return check_range(value, raw, where, what, kind, 0.0, hi, lo_open=True, guess=guess)


def _rollers(t: ToleranceSpec, where: str, layout: Layout) -> list[str]:
    """The roller names an entry's `rollers` means, in the layout's order."""
    names = [r.name for r in layout.rollers]
    given = [t.rollers] if isinstance(t.rollers, str) else list(t.rollers)
    if not given:
        raise InputError(f"{where}.rollers: empty; expected roller names, a role ({', '.join(ROLES)}) or all")
    chosen = set()
    for g in given:
        if g == "all":
            chosen.update(names)
        elif g in ROLES:
            chosen.update(r.name for r in layout.rollers if r.role == g)
        elif g in names:
            chosen.add(g)
        else:
            raise InputError(f"{where}.rollers: unknown roller '{g}'{suggest(g, names + list(ROLES))}; expected "
                             f"roller names of the variant ({', '.join(names)}), a role or all")
    out = [n for n in names if n in chosen]
    if not out:
        raise InputError(f"{where}.rollers: the variant has no {given[0]} roller")
    return out


def _forks(t: ToleranceSpec, where: str, layout: Layout) -> list[tuple[str, ...]]:
    """The forks (each as the names of its rollers, as steering.forks lists them) that carry the rollers an
    entry names; a role or all means the forks of its steering rollers."""
    named = _rollers(t, where, layout)
    role = isinstance(t.rollers, str) and t.rollers in ("all", *ROLES)
    forks = []
    for name in named:
        fork = next((f for f in layout.forks if name in f), None)
        if fork is None and not role:
            kind = next(r.role for r in layout.rollers if r.name == name)
            raise InputError(f"{where}.rollers: {name} is a {kind} roller, on no fork; expected steering rollers")
        if fork is not None and fork not in forks:
            forks.append(fork)
    if not forks:
        raise InputError(f"{where}.rollers: no steering roller among them, so no fork; expected steering rollers")
    return forks
