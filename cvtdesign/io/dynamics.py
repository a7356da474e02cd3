"""A variant's dynamic parameters (`cvtdesign transient`, docs/dynamics.md): its `dynamics:` section in SI, each
value checked positive, and the materials' densities (the materials' ageing constants, io.ageing) from which the
defaults of what it leaves out are made (core.dynamics.parameters)."""
from __future__ import annotations

import math

from cvtdesign.core.dynamics.parameters import FIELDS, DynamicParameters, default_parameters
from cvtdesign.core.layout import Layout
from cvtdesign.errors import InputError
from cvtdesign.io.ageing import material_ageing
from cvtdesign.io.schema import DynamicsSpec
from cvtdesign.io.units import to_si
from cvtdesign.io.variant import load_spec

KIND = {name: (f.json_schema_extra or {}).get("kind", "dimensionless") for name, f in DynamicsSpec.model_fields.items()}


def dynamic_parameters(layout: Layout) -> DynamicParameters:
    """The layout's DynamicParameters: its variant file's `dynamics:` section, defaults for the rest."""
    spec = load_spec(layout.file)
    given = {}
    for name in FIELDS:
        raw = getattr(spec.dynamics, name)
        if raw is None:
            continue
        where = f"{layout.file}: dynamics.{name}"
        value = to_si(raw, KIND[name], where)
        if not (isinstance(value, float) and math.isfinite(value) and value > 0):
            raise InputError(f"{where}: expected a positive value, got {raw}")
        given[name] = value
    names = {layout.sphere_material.name} | {r.material.name for r in layout.rollers}
    densities = {}
    for n in names:
        ageing = material_ageing(layout.file, spec, n)
        if "density" not in ageing.values:
            raise InputError(f"{layout.file}: materials.{n}.ageing.density: missing; expected the material's "
                             "density (its inertias' defaults are made from it), or dynamics: inertias")
        densities[n] = ageing.values["density"]
    return default_parameters(layout, densities, given)
