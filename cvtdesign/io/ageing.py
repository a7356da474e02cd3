"""The ageing constants of a variant's materials (`cvtdesign life`, docs/life.md): each constant from the most
particular place that gives it, the variant's own material first, then its libraries', then the shipped
library's material of the same name; in SI with its relative σ and its source (core.life.props.Ageing)."""
from __future__ import annotations

from cvtdesign.core.life.props import Ageing
from cvtdesign.errors import InputError
from cvtdesign.io.materials import library
from cvtdesign.io.schema import AGEING, Aged, VariantSpec
from cvtdesign.io.units import is_plain_number, parse_quantity, to_si


def material_ageing(variant_file: str, spec: VariantSpec, name: str) -> Ageing:
    """The ageing constants of material `name` as the variant sees it."""
    found: dict[str, tuple[Aged, str]] = {}
    sources = [(origin, lib.materials) for origin, lib in reversed(library(variant_file, spec))]
    sources.append((variant_file, spec.materials))
    for origin, mats in sources:
        m = mats.get(name)
        if m is None or m.ageing is None:
            continue
        for key in AGEING:
            v = getattr(m.ageing, key)
            if v is not None:
                found[key] = (v, f"{origin}: materials.{name}.ageing.{key}")
    values, std, source = {}, {}, {}
    for key, (v, where) in found.items():
        values[key], std[key] = _value(v, AGEING[key][0], where)
        source[key] = f"{v.source} ({where})"
    return Ageing(name, values, std, source)


def _value(v: Aged, kind: str, where: str) -> tuple[float, float]:
    """(SI value, relative σ) of one constant; σ written as '%' or a plain number is relative, else in the
    constant's unit."""
    value = to_si(v.value, kind, f"{where}.value")
    if not value > 0:
        raise InputError(f"{where}.value: expected a positive value, got {v.value}")
    q = parse_quantity(v.std.strip()) if isinstance(v.std, str) else None
    relative = is_plain_number(v.std) or (q is not None and q[1] is not None and str(q[1]) == "percent")
    s = to_si(v.std, "dimensionless" if relative else kind, f"{where}.std")
    if not (s >= 0):
        raise InputError(f"{where}.std: expected a standard deviation of at least 0, got {v.std}")
    return value, (s if relative else s / abs(value))


def roller_ageing(variant_file: str, spec: VariantSpec, names) -> dict[str, tuple[Ageing, Ageing]]:
    """Roller name → (its material's Ageing, the sphere's), for the rollers `names`."""
    sphere = material_ageing(variant_file, spec, spec.sphere.material)
    out = {}
    for n in names:
        r = spec.rollers[n]
        material = r.material if r.material is not None else spec.roller_defaults.material
        out[n] = (material_ageing(variant_file, spec, material), sphere)
    return out
