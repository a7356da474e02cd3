"""The plan's parts as OpenCascade solids, the clearance screen that refuses impossible geometry before
anything is written, and the STEP assembly file: written with named, coloured parts and a header that
says what it shows (variant, variant file, commanded γ, steering angle φ, cvtdesign version), and read
back (`read_step`, `read_header`). cadquery comes from `kernel()`, on first use."""
from __future__ import annotations

import itertools
import re
from importlib.metadata import version
from pathlib import Path

import numpy as np

from cvtdesign.cad.kernel import kernel
from cvtdesign.cad.plan import Plan
from cvtdesign.cad.shapes import boxes_overlap, perp, unit
from cvtdesign.errors import InputError, RunError

TOUCH_TOL = 1e-3           # [mm] two parts touch: min distance below this


def build(p: Plan) -> tuple[dict, dict]:
    """({part name: cadquery Solid}, {part name: [Solid per primitive]}) in mm; a part's primitives fused."""
    cq = kernel().cq
    shapes, pieces = {}, {}
    for part in p.parts:
        solids = pieces[part.name] = [prim.solid(cq) for prim in part.prims]
        shape = solids[0] if len(solids) == 1 else solids[0].fuse(*solids[1:]).clean()
        if len(shape.Solids()) != 1:
            raise InputError(f"{p.layout.file}: {part.field}: part {part.name} does not join into one solid (its "
                             f"pieces make {len(shape.Solids())}); expected a layout whose parts can be drawn "
                             "(docs/cad.md)")
        shapes[part.name] = shape.Solids()[0]
    return shapes, pieces


def _candidate_pairs(p: Plan, margin: float):
    """Pairs of parts whose bounding boxes (from the layout) come within `margin` [mm] of each other."""
    boxes = {part.name: part.bbox() for part in p.parts}
    return [(a, b) for a, b in itertools.combinations(p.parts, 2) if boxes_overlap(boxes[a.name], boxes[b.name], margin)]


def _directions(n=256):
    """n unit vectors spread evenly over the sphere (Fibonacci lattice)."""
    i = np.arange(n) + 0.5
    z, phi = 1 - 2 * i / n, np.pi * (1 + 5 ** 0.5) * i
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


DIRECTIONS = _directions()


def hull_gap(pa, pb) -> float:
    """A lower bound on the distance [mm] between two primitives: the best separating-axis gap
    g(m) = −(h_a(m) + h_b(−m)) over unit directions m (h the support functions), which for convex bodies
    equals their distance at the optimum: the best of 256 spread directions and the line between the boxes'
    centres, then a pattern search on the sphere. A wheel's bore and a sub-arc's curvature make their hulls
    larger, so it stays a lower bound."""
    gap = lambda m: -(pa.support(m) + pb.support(-m))
    d = pb.box.mean(axis=0) - pa.box.mean(axis=0)
    cands = np.vstack([unit(d) if np.linalg.norm(d) > 1e-9 else DIRECTIONS[0], DIRECTIONS])
    gaps = gap(cands)
    m, g = cands[np.argmax(gaps)], float(np.max(gaps))
    step = 0.1
    while g <= 1.0 and step > 1e-5:
        t1 = perp(m)
        t2 = np.cross(m, t1)
        trial = np.array([unit(m + step * t) for t in (t1, -t1, t2, -t2, t1 + t2, t1 - t2, t2 - t1, -t1 - t2)])
        gaps = gap(trial)
        if gaps.max() > g:
            m, g = trial[np.argmax(gaps)], float(gaps.max())
        else:
            step /= 2
    return g


def _may_touch(a, b, pieces) -> bool:
    """Whether any primitive pair of parts a and b has convex hulls within 1 mm (`hull_gap`) and their
    OpenCascade solids within TOUCH_TOL."""
    k = kernel()
    for (pa, sa), (pb, sb) in itertools.product(zip(a.prims, pieces[a.name]), zip(b.prims, pieces[b.name])):
        if not boxes_overlap(pa.box, pb.box, 1.0):
            continue
        if all(hull_gap(x, y) > 1.0 for x in pa.pieces for y in pb.pieces if boxes_overlap(x.box, y.box, 1.0)):
            continue
        d = k.DistShapeShape(sa.wrapped, sb.wrapped)
        if d.IsDone() and d.Value() <= TOUCH_TOL:
            return True
    return False


def screen(p: Plan, pieces: dict):
    """Refuse impossible geometry before anything is written: every two parts not built to touch must be
    apart (min distance > TOUCH_TOL). Primitive pairs whose convex hulls are more than 1 mm apart
    (`hull_gap`) pass at once; the others are measured on their OpenCascade solids. A wheel and its own
    axle are coaxial by construction (radial clearance BORE_CLEARANCE) and are left to `checks.check_step`.
    One InputError line naming the file and the field."""
    touching = p.touching()
    for a, b in _candidate_pairs(p, 1.0):
        if frozenset((a.name, b.name)) in touching or (a.roller and a.roller == b.roller):
            continue
        if _may_touch(a, b, pieces):
            first, second = (b, a) if a.kind == "sphere" or (a.kind == "roller" and b.kind != "roller") else (a, b)
            other = second.name if second.field == second.name else f"{second.name} ({second.field})"
            raise InputError(f"{p.layout.file}: {first.field}: part {first.name} runs into {other} at γ = "
                             f"{np.degrees(p.gamma):g}°; expected every part clear of the others (only rollers "
                             "touch the sphere)")


def assembly(p: Plan, shapes: dict):
    """The cadquery Assembly of the plan's parts, named and coloured as planned."""
    cq = kernel().cq
    assy = cq.Assembly(name=p.layout.name)
    for part in p.parts:
        assy.add(shapes[part.name], name=part.name, color=cq.Color(*part.colour))
    return assy


# --- the STEP file -----------------------------------------------------------------------------------------

def step_header(p: Plan, file_name: str) -> dict:
    """The STEP header's fields for the plan (ASCII text; a variant's name and file as given):
    FILE_NAME's name (the file's own name, `file_name`) and originating system (`cvtdesign <version>`),
    empty author, organisation and authorisation, and FILE_DESCRIPTION's lines `key: value`: the variant,
    the variant file, the commanded γ [deg], the steering angle φ [deg] and the cvtdesign version."""
    made_by = f"cvtdesign {version('cvtdesign')}"
    return {"name": file_name, "author": [""], "organization": [""], "originating_system": made_by,
            "authorisation": "",
            "description": [f"variant: {p.layout.name}", f"variant file: {p.layout.file}",
                            f"commanded gamma [deg]: {np.degrees(p.gamma):.12g}",
                            f"steering angle phi [deg]: {np.degrees(p.phi):.12g}", f"written by: {made_by}"]}


def _set_header(k, model, header: dict):
    """Fill the header of the writer's STEP model (OCP's APIHeaderSection_MakeHeader)."""
    h = k.MakeHeader(model)
    text = k.HAsciiString
    lists = {"description": (h.SetDescription, header["description"]), "author": (h.SetAuthor, header["author"]),
             "organization": (h.SetOrganization, header["organization"])}
    for setter, values in lists.values():
        array = k.HArray1OfHAsciiString(1, len(values))
        for i, value in enumerate(values, 1):
            array.SetValue(i, text(value))
        setter(array)
    h.SetName(text(header["name"]))
    h.SetOriginatingSystem(text(header["originating_system"]))
    h.SetAuthorisation(text(header["authorisation"]))


def write_step(assy, path: Path, header: dict):
    """Write the assembly as a STEP AP214 file in mm, parts named and coloured (as cadquery's
    `exportAssembly` does), with the header `header` (see `step_header`)."""
    k = kernel()
    _, doc = k.toCAF(assy, True)
    writer = k.STEPCAFControl_Writer(k.WorkSession(), False)
    writer.SetColorMode(True)
    writer.SetLayerMode(True)
    writer.SetNameMode(True)
    for key, value in (("write.surfacecurve.mode", 1), ("write.precision.mode", 0), ("write.stepcaf.subshapes.name", 1)):
        k.Static.SetIVal_s(key, value)
    k.Static.SetCVal_s("xstep.cascade.unit", "MM")
    k.Static.SetCVal_s("write.step.unit", "MM")
    writer.Transfer(doc, k.as_is)
    _set_header(k, writer.ChangeWriter().Model(), header)
    if writer.Write(str(path)) != k.written:
        raise RunError(f"the STEP writer failed for {path}")


def read_step(path: Path) -> dict:
    """{part name: (shape placed in N [mm], colour RGB or None)} from a STEP assembly (XCAF reader)."""
    assy = kernel().cq.Assembly.importStep(str(path))
    out = {}
    for child in assy.children:
        shape = child.obj.moved(child.loc) if child.obj is not None else None
        out[child.name] = (shape, None if child.color is None else child.color.toTuple()[:3])
    return out


_TOKEN = re.compile(r"'(?:[^']|'')*'|[(),]|[^'(),\s]+")


def _parameters(text: str, start: int) -> list:
    """The parameter list of a STEP (ISO 10303-21) entity opening at text[start] == '(': nested lists of
    strings (quotes undone) and bare tokens ($, numbers)."""
    stack = [[]]
    for m in _TOKEN.finditer(text, start):
        tok = m.group()
        if tok == "(":
            stack.append([])
        elif tok == ")":
            done = stack.pop()
            stack[-1].append(done)
            if len(stack) == 1:
                return done
        elif tok != ",":
            stack[-1].append(tok[1:-1].replace("''", "'") if tok.startswith("'") else tok)
    raise ValueError(f"unbalanced parentheses in the STEP header: {text[start:start + 80]}")


def read_header(path: Path) -> dict:
    """The header of a STEP file: {description: [...], implementation_level, name, time_stamp, author: [...],
    organization: [...], preprocessor_version, originating_system, authorisation} (strings). Lines are
    joined first: a writer breaks long strings across lines, which the format ignores."""
    lines = []
    with open(path, encoding="utf-8", errors="replace") as f:
        for line in f:
            if line.startswith("ENDSEC"):
                break
            lines.append(line.rstrip("\r\n"))
    head = "".join(lines)
    fields = {}
    for entity, keys in (("FILE_DESCRIPTION", ("description", "implementation_level")),
                         ("FILE_NAME", ("name", "time_stamp", "author", "organization", "preprocessor_version",
                                        "originating_system", "authorisation"))):
        m = re.search(entity + r"\s*\(", head)
        if m is None:
            raise ValueError(f"{path}: no {entity} in the STEP header")
        fields.update(zip(keys, _parameters(head, m.end() - 1)))
    return fields
