"""The materials library: materials by name, the friction of each pair of materials, and the calibrations that
make the contact theory match a measured machine, with their uncertainty and provenance (docs/materials.md).

The shipped library is cvtdesign/materials.yaml. A variant adds files of its own (`material_library:`), in the
same format, which take precedence; `cvtdesign diagnose --save-calibration FILE` writes one. A variant's own
`materials:` entries take precedence over both.

A calibration belongs to a roller material on a sphere material: the roller's creep modulus, the Young's
modulus with which Hertz + Kalker give the measured creep compliance (the Hertz patch keeps the nominal
modulus). It applies to a contact whose two materials are the calibration's, with the library's elastic
constants (a variant that redefines a material under the same name with other values gets no calibration,
and is told so). `contact_calibration` decides, per roller, where its creep compliance comes from: the
variant's own constants (which name their pair: `check_fitted_pair`), a library calibration, a calibration
`transferred` from materials of the same family, or the theory alone. Friction belongs to a pair, never to one
material: `pair_friction` finds the pair's entry or refuses the contact.
"""
from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import yaml
from pydantic import Field

from cvtdesign.core.contact.patch import calibrated_compliance, creep_modulus_for
from cvtdesign.core.layout import CreepSource, Friction, Layout
from cvtdesign.errors import InputError, suggest
from cvtdesign.io.schema import MaterialSpec, Num, PairSpec, Strict, VariantSpec, spec_field
from cvtdesign.io.units import check_range, to_si
from cvtdesign.io.yaml_file import read_spec

SHIPPED = Path(__file__).resolve().parents[1] / "materials.yaml"
THEORY_GAP = "Hertz + Kalker alone is 3.1–3.6× stiffer than Kim et al.'s CVT measured"


class CalibrationSpec(Strict):
    """A calibration of the contact law for a roller material on a sphere material."""
    roller: str = spec_field("the roller's material, a name in the library")
    sphere: str = spec_field("the sphere's material, a name in the library")
    creep_modulus: Num = spec_field("the roller's Young's modulus in tangential creep", kind="pressure")
    std: Num = spec_field("its relative standard deviation (1σ), e.g. '1.3 %'", kind="dimensionless")
    preload: Num | None = spec_field("the normal force the measured machine ran at (its assumed value where the "
                                     "source states none)", None, kind="force")
    machine: str = spec_field("the machine it was measured on")
    data: str = spec_field("the data it was fitted to")
    fit: str = spec_field("how it was fitted")


class LibrarySpec(Strict):
    """A materials library file."""
    materials: dict[str, MaterialSpec] = Field(default_factory=dict)
    pairs: list[PairSpec] = Field(default_factory=list)
    calibrations: list[CalibrationSpec] = Field(default_factory=list)


@functools.cache
def _read(path: str, mtime: float) -> LibrarySpec:
    return read_spec(path, LibrarySpec, "materials, pairs, calibrations")


def library(variant_file: str, spec: VariantSpec) -> list[tuple[str, LibrarySpec]]:
    """The libraries a variant sees, most particular first: its own files, then the shipped one."""
    folder = Path(variant_file).parent
    files = [folder / f for f in spec.material_library] + [SHIPPED]
    out = []
    for i, f in enumerate(files):
        where = str(f) if f == SHIPPED else f"{variant_file}: material_library[{i}]"
        if f.is_file() and Path(variant_file).is_file() and f.samefile(variant_file):
            raise InputError(f"{where}: '{f.name}' is the variant itself; expected a materials library (docs/materials.md)")
        if not f.is_file():
            raise InputError(f"{where}: no such file {f}; expected a materials library (docs/materials.md)")
        lib = _read(str(f), f.stat().st_mtime)
        out.append(("cvtdesign's materials library" if f == SHIPPED else str(f), lib))
    return out


def material_specs(variant_file: str, spec: VariantSpec) -> dict[str, tuple[MaterialSpec, str]]:
    """name → (spec, where it is defined) of every material the variant can name: its own first. Every
    calibration of the libraries it sees is checked on the way (`check_calibration`)."""
    out, libs = {}, library(variant_file, spec)
    for origin, lib in reversed(libs):
        out.update({k: (m, f"{origin}: materials.{k}") for k, m in lib.materials.items()})
    out.update({k: (m, f"{variant_file}: materials.{k}") for k, m in spec.materials.items()})
    for origin, lib in libs:
        for i, c in enumerate(lib.calibrations):
            check_calibration(c, f"{origin}: calibrations[{i}]", out)
    return out


# plausible ranges of a calibration's numbers: (what, kind, lower, upper, the unit a plain number probably meant);
# the creep modulus as the variant's Young's moduli (io.variant.PLAUSIBLE), σ above 0 and at most 100 %
CALIBRATION_RANGES = {"creep_modulus": ("creep modulus", "pressure", 1e5, 1.2e12, "MPa"),
                      "std": ("relative standard deviation", "dimensionless", 0.0, 1.0, "%")}


def check_calibration(c: CalibrationSpec, where: str, known: dict) -> tuple[float, float]:
    """A library calibration's (creep modulus [Pa], σ): both materials among the `known` names (a misspelt one
    is refused with the nearest, never left to turn its rollers to theory only), each number of
    CALIBRATION_RANGES finite and plausible; one InputError line naming the file and field otherwise."""
    for field in ("roller", "sphere"):
        name = getattr(c, field)
        if name not in known:
            raise InputError(f"{where}.{field}: unknown material '{name}'{suggest(name, known)}; expected a material "
                             "of the variant or of a library it names (docs/materials.md)")
    out = []
    for field, (what, kind, lo, hi, guess) in CALIBRATION_RANGES.items():
        raw = getattr(c, field)
        out.append(check_range(to_si(raw, kind, f"{where}.{field}"), raw, f"{where}.{field}", what, kind, lo, hi,
                               lo_open=True, guess=guess))
    return out[0], out[1]


def library_calibration(variant_file: str, spec: VariantSpec, roller_material: str, sphere_material: str):
    """The first library calibration of (roller material, sphere material) with its source file, or
    (None, a reason it does not apply or '')."""
    own = spec.materials
    for origin, lib in library(variant_file, spec):
        for i, c in enumerate(lib.calibrations):
            if (c.roller, c.sphere) != (roller_material, sphere_material):
                continue
            changed = [m for m in (c.roller, c.sphere) if m in own and m in lib.materials
                       and _elastic(own[m]) != _elastic(lib.materials[m])]
            if changed:
                return None, (f"{', '.join(changed)} differs from the library's, so its calibration "
                              f"({origin}) does not apply")
            return (c, f"{origin}: calibrations[{i}]"), ""
    return None, ""


def _elastic(m: MaterialSpec) -> tuple:
    return (to_si(m.youngs_modulus, "pressure", "E"), to_si(m.poisson_ratio, "dimensionless", "ν"))


def check_pair(p: PairSpec, where: str, known: dict) -> tuple[float, float, float]:
    """A pair's (μ, low, high): two known materials, each number a plausible friction coefficient (0 < μ ≤ 3),
    low ≤ μ ≤ high; one InputError line naming the file and field otherwise."""
    for which in ("materials", "range"):
        if len(getattr(p, which)) != 2:
            raise InputError(f"{where}.{which}: expected two values, got {len(getattr(p, which))}")
    for k, name in enumerate(p.materials):
        if name not in known:
            raise InputError(f"{where}.materials.{k}: unknown material '{name}'{suggest(name, known)}; expected a "
                             "material of the variant or of a library it names (docs/materials.md)")
    mu, lo, hi = (check_range(to_si(v, "dimensionless", f"{where}.{f}"), v, f"{where}.{f}", "friction coefficient",
                              "dimensionless", 0.0, 3.0, lo_open=True, guess=None)
                  for v, f in ((p.friction, "friction"), (p.range[0], "range.0"), (p.range[1], "range.1")))
    if not lo <= mu <= hi:
        raise InputError(f"{where}.range: expected low <= friction <= high, got {lo:g} <= {mu:g} <= {hi:g}")
    return mu, lo, hi


def pair_friction(variant_file: str, spec: VariantSpec, roller: str, roller_material: str,
                  sphere_material: str) -> Friction:
    """The friction of a roller material on a sphere material: the variant's own `pairs` entry for the two,
    else the first library's; a pair no file lists is one InputError line naming it (friction belongs to the
    pair: no rule makes it from the two materials). Every pair the variant sees is checked (`check_pair`)."""
    known = material_specs(variant_file, spec)
    entries = [(f"{variant_file}: pairs.{i}", p) for i, p in enumerate(spec.pairs)] + \
        [(f"{origin}: pairs.{i}", p) for origin, lib in library(variant_file, spec) for i, p in enumerate(lib.pairs)]
    checked = [(at, p, check_pair(p, at, known)) for at, p in entries]
    for at, p, (mu, lo, hi) in checked:
        if set(p.materials) == {roller_material, sphere_material}:
            return Friction(mu, lo, hi, f"{roller_material} on {sphere_material}: μ {mu:g} ({lo:g}–{hi:g}; "
                                        f"{p.source}; {at})")
    raise InputError(f"{variant_file}: rollers.{roller}: no friction known for {roller_material} on {sphere_material}; "
                     f"expected a `pairs` entry for the two in the variant or its material_library: {{materials: "
                     f"[{roller_material}, {sphere_material}], friction: μ, range: [low, high], source: ...}} "
                     "(docs/materials.md, 'Friction')")


def check_fitted_pair(variant_file: str, spec: VariantSpec, roller: str, role: str, roller_material: str,
                      sphere_material: str) -> None:
    """A fitted creep constant belongs to the pair of materials it was fitted for (contact.fitted_on): a
    roller of another pair is one InputError line, and so is a constant that does not say its pair."""
    side = "drive" if role != "steering" else "steering"
    if getattr(spec.contact, f"creep_{side}") is None:
        return
    pair = getattr(spec.contact.fitted_on, side)
    w = f"{variant_file}: contact.fitted_on.{side}"
    if pair is None:
        raise InputError(f"{w}: creep_{side} is given without the materials it was fitted for; expected "
                         f"[roller material, sphere material] (a constant fitted on one pair says nothing of another)")
    if len(pair) != 2:
        raise InputError(f"{w}: expected two material names [roller, sphere], got {len(pair)}")
    if tuple(pair) != (roller_material, sphere_material):
        raise InputError(f"{variant_file}: rollers.{roller}: {roller_material} on {sphere_material}, but "
                         f"contact.creep_{side} was fitted for {pair[0]} on {pair[1]}; expected the constants "
                         f"removed (the materials library then calibrates the pair) or refitted for these materials")


def contact_calibration(variant_file: str, spec: VariantSpec, role: str, roller_material: str,
                        sphere_material: str) -> CreepSource:
    """Where a contact's creep compliance comes from, in this order: the variant's own constants (a
    fitted law's creep_drive or creep_steering, or the calibration factors on a theory, with
    contact.uncertainty), a library
    calibration of its two materials, else the theory alone (uncalibrated)."""
    c, side = spec.contact, "drive" if role != "steering" else "steering"
    source = functools.partial(CreepSource, materials=(roller_material, sphere_material))
    std = getattr(c.uncertainty, side)
    std = None if std is None else to_si(std, "dimensionless", f"{variant_file}: contact.uncertainty.{side}")
    fitted = c.creep_drive if side == "drive" else c.creep_steering
    if fitted is not None:                  # only a law that takes fitted constants has them (io.variant)
        return source("fitted", f"the variant's fitted creep_{side} = {fitted}", std)
    factor = getattr(c.calibration, side)
    if factor is not None:                  # only a law that takes calibration factors has them
        if isinstance(factor, (int, float)) and factor == 1:
            return source("theory", f"theory only: contact.calibration.{side} = 1, the theory as it stands "
                                    f"({THEORY_GAP})")
        return source("factor", f"the variant's contact.calibration.{side} = {factor}", std)
    found, reason = library_calibration(variant_file, spec, roller_material, sphere_material)
    if found is None:
        moved = transferred(variant_file, spec, roller_material) if not reason else None
        if moved is not None:
            return source("transferred", moved["source"], moved["std"], moved["creep_modulus"],
                          preload=moved["preload"])
        why = f"; {reason}" if reason else ""
        return source("theory", f"theory only: no calibration of {roller_material} on {sphere_material}{why} "
                                f"({THEORY_GAP})")
    cal, at = found
    E, s = check_calibration(cal, at, {roller_material, sphere_material})
    return source("library", f"{roller_material} on {sphere_material}: creep modulus {cal.creep_modulus} "
                             f"± {s:.1%} ({cal.machine}; {at})", s, E,
                  preload=None if cal.preload is None else to_si(cal.preload, "force", f"{at}.preload"))


TRANSFER_STD = 0.10   # the least relative 1σ of a transferred calibration: its 95 % interval (±20 %) holds the
                      # spread of the correction on Kim's machine (3.1× at the drive rollers, 3.6× at the steering)


def transferred(variant_file: str, spec: VariantSpec, roller_material: str) -> dict | None:
    """A best estimate for a roller material with no calibration of its own: the ratio of nominal to creep
    modulus that the library's calibrations of materials of the same `family` give (their geometric mean),
    applied to its own modulus, with σ the larger of TRANSFER_STD and half their spread (in log); None where
    the material has no family or no calibration of its family exists."""
    specs = material_specs(variant_file, spec)
    family = specs[roller_material][0].family if roller_material in specs else None
    if family is None:
        return None
    ratios, preloads, names = [], set(), []
    for origin, lib in library(variant_file, spec):
        for i, c in enumerate(lib.calibrations):
            own = specs.get(c.roller)
            if own is None or own[0].family != family:
                continue
            at = f"{origin}: calibrations[{i}]"
            ratios.append(to_si(own[0].youngs_modulus, "pressure", f"{own[1]}.youngs_modulus")
                          / to_si(c.creep_modulus, "pressure", f"{at}.creep_modulus"))
            preloads.add(None if c.preload is None else to_si(c.preload, "force", f"{at}.preload"))
            names.append(f"{c.roller} on {c.sphere}")
    if not ratios:
        return None
    logs = np.log(ratios)
    r = float(np.exp(np.mean(logs)))
    std = max(TRANSFER_STD, float(np.ptp(logs)) / 2)
    E = to_si(specs[roller_material][0].youngs_modulus, "pressure", f"{specs[roller_material][1]}.youngs_modulus")
    return {"creep_modulus": E / r, "std": std, "preload": preloads.pop() if len(preloads) == 1 else None,
            "source": f"TRANSFERRED to {roller_material}: its modulus / {r:.3g}, the {family} correction that "
                      f"calibrates {', '.join(names)} (± {std:.0%}, a best estimate, not a measurement)"}


def fitted_calibrations(layout: Layout, scales: dict, machine: str, data: str, fit: str) -> list[dict]:
    """Library calibrations (one per roller material on the sphere's) from a diagnosis's fitted compliance
    scales {role: (scale, σ)} ('drive', 'steering'; the scales of the creep effects,
    core.effects.CALIBRATION): each roller's fitted compliance is scale × the compliance its law used
    (core.contact.patch.calibrated_compliance), and its creep modulus the one that gives it. A material
    whose rollers give different moduli (several roles, or fitted constants that ignored their geometry) gets
    their mean, the spread added to its σ."""
    moduli: dict = {}
    for r in layout.rollers:
        role = "steering" if r.role == "steering" else "drive"
        if role not in scales:
            continue
        s, sd = scales[role]
        E = creep_modulus_for(layout, r, s * calibrated_compliance(layout, r))
        moduli.setdefault(r.creep.materials, []).append((E, sd / s, role))
    out = []
    for (roller, sphere), found in moduli.items():
        E = np.array([f[0] for f in found])
        std = float(np.hypot(max(f[1] for f in found), np.std(E) / np.mean(E)))
        roles = sorted({f[2] for f in found})
        out.append({"roller": roller, "sphere": sphere, "creep_modulus": f"{np.mean(E) / 1e6:.4g} MPa",
                    "std": f"{100 * std:.2g} %", "machine": machine, "data": data,
                    "fit": f"{fit}; from the {' and '.join(roles)} contacts ({len(found)} rollers)"})
    return out


def saved_library(path, spec: VariantSpec, entries: list[dict]) -> str:
    """The text of library file `path` with `entries` added: an existing library keeps its other entries (one
    of the same pair is replaced); the variant `spec`'s own definitions of the entries' materials are written
    with them, so that a variant naming the file gets the same materials the calibration was fitted with."""
    path = Path(path)
    old = read_spec(str(path), LibrarySpec, "materials, calibrations") if path.is_file() else LibrarySpec()
    data = old.model_dump(exclude_defaults=True, exclude_none=True)
    pairs = {(e["roller"], e["sphere"]) for e in entries}
    data["calibrations"] = [c for c in data.get("calibrations", []) if (c["roller"], c["sphere"]) not in pairs]
    data["calibrations"] += entries
    own = spec.materials
    for name in sorted({m for e in entries for m in (e["roller"], e["sphere"])} & set(own)):
        data.setdefault("materials", {})[name] = own[name].model_dump(exclude_defaults=True, exclude_none=True)
    return HEADER + yaml.safe_dump(data, sort_keys=False, allow_unicode=True, width=110)


HEADER = ("# A materials library (docs/materials.md), written by `cvtdesign diagnose --save-calibration`.\n"
          "# A variant uses it with `material_library: [this file]`.\n")
