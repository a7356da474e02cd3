"""A commented variant file to start from (`cvtdesign new`): a shipped variant's values, written field by
field with the schema's description of each field (io.schema, the one source of these texts) as a comment
above it.

Each field of the schema is explained once, where it first appears (the first roller's fields, the first
material's); later rollers and materials repeat no comments. The template's own notes on its named
`parameters` ("# sphere radius") are kept beside them. The values are the template's, so the file describes
the same machine: `cvtdesign compare` gives it the template's figures.
"""
from __future__ import annotations

import re
import textwrap
import typing
from pathlib import Path

import yaml
from pydantic import TypeAdapter, ValidationError

from cvtdesign.errors import InputError
from cvtdesign.io.output import write_file
from cvtdesign.io.reference import nested_model
from cvtdesign.io.schema import Name, Spherical, VariantSpec
from cvtdesign.io.shipped import SHIPPED, shipped_variant
from cvtdesign.io.yaml_file import load_yaml

WIDTH = 110     # columns of the comment lines


def check_name(name: str, where: str) -> str:
    """The variant name, or one InputError line: the schema's rule for `name` (it becomes part of file names)."""
    try:
        return TypeAdapter(Name).validate_python(name)
    except ValidationError as err:
        raise InputError(f"{where}: {err.errors()[0]['msg']}") from None


def flow(value) -> str:
    """One YAML value on one line, quoted where YAML needs it; an expression always ('= R' → \"'= R'\")."""
    if isinstance(value, str) and value.lstrip().startswith("="):
        return "'" + value.replace("'", "''") + "'"
    text = yaml.safe_dump(value, default_flow_style=True, allow_unicode=True, width=10**6, sort_keys=False)
    return text.removesuffix("\n").removesuffix("\n...").strip()


def parameter_notes(text: str) -> dict[str, str]:
    """The trailing comments of a variant file's `parameters:` entries ('R: 63.5 mm   # sphere radius')."""
    notes, inside = {}, False
    for line in text.splitlines():
        if re.match(r"\S", line):
            inside = line.startswith("parameters:")
            continue
        m = re.match(r"\s+([A-Za-z_]\w*)\s*:[^#]*#\s*(.+)$", line) if inside else None
        if m:
            notes[m[1]] = m[2].strip()
    return notes


class _Writer:
    """Writes the lines of a commented variant: `mapping` walks a schema model and its data together."""

    def __init__(self, notes: dict[str, str]):
        self.lines: list[str] = []
        self.explained: set[tuple[type, str]] = set()
        self.notes = notes

    def comment(self, model, name: str, indent: int):
        """The field's description above it, the first time the field of that model is written."""
        if (model, name) in self.explained:
            return
        self.explained.add((model, name))
        text = model.model_fields[name].description
        self.lines += [" " * indent + "# " + line for line in textwrap.wrap(text, WIDTH - indent - 2)]

    def mapping(self, model, data: dict, indent: int, dash: bool = False):
        """The fields of `data` (a mapping of `model`) at `indent`; with `dash`, as a YAML list item."""
        for i, (name, value) in enumerate(data.items()):
            first_of_item = dash and i == 0
            if indent == 0 and self.lines:
                self.lines.append("")          # a blank line between the top-level sections
            self.comment(model, name, indent - 2 if first_of_item else indent)
            lead = " " * (indent - 2) + "- " if first_of_item else " " * indent
            self.value(lead, name, value, _nested(model.model_fields[name].annotation, value), indent)

    def value(self, lead: str, name: str, value, nested, indent: int):
        if nested is None or not value:
            if isinstance(value, dict) and value:         # parameters, effect_parameters: a block of values
                self.lines.append(f"{lead}{name}:")
                self.plain_block(value, indent + 2, notes=self.notes if name == "parameters" else {})
            else:
                self.lines.append(f"{lead}{name}: {flow(value)}")
            return
        shape, sub = nested
        self.lines.append(f"{lead}{name}:")
        if shape == "model":
            self.mapping(sub, value, indent + 2)
        elif shape == "dict":
            for key, item in value.items():
                self.lines.append(f"{' ' * (indent + 2)}{flow(key)}:")
                self.mapping(sub, item, indent + 4)
        else:
            for item in value:
                self.mapping(sub, item, indent + 4, dash=True)

    def plain_block(self, data: dict, indent: int, notes: dict):
        for key, v in data.items():
            if isinstance(v, dict):
                self.lines.append(f"{' ' * indent}{flow(key)}:")
                self.plain_block(v, indent + 2, {})
            else:
                note = f"   # {notes[key]}" if key in notes else ""
                self.lines.append(f"{' ' * indent}{flow(key)}: {flow(v)}{note}")


def _nested(annotation, value):
    """(shape, model) of a field's value that is written as a nested model (reference.nested_model), or a
    direction written as {polar, azimuth}; None for a plain value."""
    if isinstance(value, dict) and Spherical in typing.get_args(annotation):
        return "model", Spherical
    return nested_model(annotation)


STEERING_COUNTS = (2, 3, 4)     # `new --steering N`: one or two steering rollers at each pole
PAIR_POLAR = "asin(d / (2*R))"  # polar angle of a steering pair's contacts, a chord d apart (the box's)


def _steering_group(prefix: str, count: int, north: bool) -> dict:
    """The contacts of `count` (1 or 2) steering rollers at one pole, named prefix1, prefix2: one at the
    pole, or the box's pair a chord d apart across it in the plane ⟂ d1. Every contact lies in that plane,
    so the axle d1 passes through the commanded axis u(0) = d1 (docs/linkages.md)."""
    if count == 1:
        return {f"{prefix}1": {"contact": "z" if north else "-z"}}
    polar = f"= {PAIR_POLAR}" if north else f"= pi - {PAIR_POLAR}"
    return {f"{prefix}{k + 1}": {"contact": {"polar": polar, "azimuth": az}} for k, az in enumerate(("135 deg", "-45 deg"))}


def with_steering(data: dict, count: int) -> dict:
    """The box template's data with `count` steering rollers (STEERING_COUNTS) in place of its four: a group
    at each pole (N: ⌈count/2⌉, S: ⌊count/2⌋), each group on one fork about the pole axis z with ratio 1,
    so that every roller's axis turns with φ alike (γ = φ; docs/linkages.md). A lone roller opposite a
    pair carries the pair's preload along z (2·preload·cos θ), so that the preloads balance."""
    if count not in STEERING_COUNTS:
        raise InputError(f"--steering: {count} steering rollers; expected one of {', '.join(map(str, STEERING_COUNTS))} "
                         "(a pair or one roller at each pole; other linkages: docs/linkages.md)")
    north, south = (count + 1) // 2, count // 2
    steer = next(r for r in data["rollers"].values() if r["role"] == "steering")
    rollers = {k: r for k, r in data["rollers"].items() if r["role"] != "steering"}
    forks = []
    for prefix, k, is_north in (("N", north, True), ("S", south, False)):
        group = _steering_group(prefix, k, is_north)
        for rn, place in group.items():
            rollers[rn] = {"role": "steering", **place, "axle": "d1",
                           **{f: steer[f] for f in ("radius", "crown_radius", "material")}}
            if k == 1 and north != south:
                rollers[rn]["preload"] = f"= 2*preload*cos({PAIR_POLAR})"
        forks.append({"rollers": list(group), "axis": "z", "ratio": 1})
    parameters = {k: v for k, v in data["parameters"].items() if k != "d" or north == 2}
    return {**data, "description": f"{count} steering rollers at the poles on forks about the pole axis, with the box "
            "CVT's drive and follower rollers", "parameters": parameters, "rollers": rollers, "steering": {"forks": forks}}


def commented_variant(template: str, name: str, file: str | None = None, steering: int | None = None) -> str:
    """The text of a new variant `name`: the shipped variant `template` with a comment on its fields, or
    with `steering` steering rollers (`with_steering`, from the box template); `file` is where it will be
    written (for the header's `compare` line; default NAME.yaml)."""
    if template not in SHIPPED:
        raise InputError(f"--template: unknown template '{template}'; expected one of {', '.join(SHIPPED)}")
    path = shipped_variant(template)
    data = {**load_yaml(path), "name": name}
    if steering is not None:
        if template != "box":
            raise InputError(f"--steering: builds on the box template (drive and follower rollers whose preloads "
                             f"balance on their own), not '{template}'; expected --template box or no --template")
        data = with_steering(data, steering)
    writer = _Writer(parameter_notes(Path(path).read_text(encoding="utf-8")))
    writer.mapping(VariantSpec, data, 0)
    shown = file if file and file.isprintable() else f"{name}.yaml"     # a comment line holds no line break
    origin = f"'{template}' variant" + (f" with {steering} steering rollers" if steering is not None else "")
    head = [f"# {name}: a spherical CVT, started from cvtdesign's {origin} by `cvtdesign new`.",
            "# Plain numbers are SI (m, N, Pa, N/m, 1/N, rad, N*m, rad/s); a quantity carries its unit (\"40 mm\");",
            "# \"= expr\" is computed from `parameters`. Every field, its unit, default and plausible range:",
            "# docs/variant-reference.md; frames, signs, γ and α: docs/conventions.md.",
            f"# Check it: cvtdesign compare {shown}", ""]
    return "\n".join(head + writer.lines) + "\n"


def write_new_variant(name: str, template: str, out=None, steering: int | None = None) -> Path:
    """Write the commented variant `name` (from the shipped `template`, with `steering` steering rollers if
    given) to `out` (default NAME.yaml here); an existing file is refused (one InputError line, nothing
    written). Returns the path written."""
    check_name(name, "NAME")
    target = Path(out) if out else Path(f"{name}.yaml")
    kind = "--out" if out else "NAME.yaml"
    if target.exists() or target.is_symlink():
        raise InputError(f"{target}: already exists; expected a new file name (another NAME or --out FILE; "
                         "cvtdesign new never overwrites a file)")
    text = commented_variant(template, name, str(target), steering)
    return write_file(target, text, kind=kind)
