"""Checks of a written STEP file against the plan it was made from (`cvtdesign export --check`): the file
is read back (`step.read_step`, `step.read_header`) and measured with OpenCascade."""
from __future__ import annotations

import itertools
from importlib.metadata import version
from pathlib import Path

import numpy as np

from cvtdesign.cad.kernel import kernel
from cvtdesign.cad.plan import Plan, mm, named_by_role
from cvtdesign.cad.shapes import boxes_overlap
from cvtdesign.cad.step import TOUCH_TOL, read_header, read_step

VOLUME_TOL = 1e-3          # [mm³] intersection volume counted as interference above this
BBOX_TOL = 1e-3            # [mm] STEP bounding box against the one computed from the layout
CONTACT_TOL = 1e-3         # [mm] the wheel touches the sphere at R·n
ANGLE_TOL = 1e-6           # [deg] γ and φ in the header against the plan's


def _row(check, ok, detail) -> dict:
    return {"check": check, "ok": bool(ok), "detail": detail}


def _common_volume(a, b) -> float:
    k = kernel()
    op = k.Common(a.wrapped, b.wrapped)
    if not op.IsDone():
        return float("inf")
    return k.cq.Shape.cast(op.Shape()).Volume()


def _bbox(shape) -> np.ndarray:
    bb = shape.BoundingBox()          # BRepBndLib::AddOptimal: exact for these surfaces
    return np.array([[bb.xmin, bb.ymin, bb.zmin], [bb.xmax, bb.ymax, bb.zmax]])


def _names_rows(parts: dict, p: Plan) -> list[dict]:
    """Names and count as planned, every name by role, one valid solid per part, colours as planned."""
    expected, got = p.names(), list(parts)
    rows = [_row("names and count", got == expected, f"{len(got)} parts" + ("" if got == expected else
                 f"; expected {len(expected)}: missing {sorted(set(expected) - set(got))}, "
                 f"unexpected {sorted(set(got) - set(expected))}"))]
    bare = [n for n in got if not named_by_role(n, p.layout)]
    rows.append(_row("part names by role", not bare, f"all {len(got)} ({', '.join(got[1:4])}, …)" if not bare
                     else f"not named by role: {bare}"))
    bad = [n for n, (s, _) in parts.items() if s is None or len(s.Solids()) != 1 or not s.Solids()[0].isValid()]
    rows.append(_row("one valid solid per part", not bad, "all valid" if not bad else f"invalid or not one solid: {bad}"))
    colour = {part.name: part.colour for part in p.parts}
    off = [n for n, (_, c) in parts.items() if c is None or n not in colour or np.max(np.abs(np.subtract(c, colour[n]))) > 1e-3]
    rows.append(_row("colours", not off, "as planned" if not off else f"wrong or missing: {off}"))
    return rows


def _header_row(path: Path, p: Plan) -> dict:
    """The header names the variant, its file, the commanded γ, the steering angle φ and cvtdesign's version."""
    try:
        head = read_header(path)
    except ValueError as e:
        return _row("header", False, str(e))
    said = dict(line.split(": ", 1) for line in head["description"] if isinstance(line, str) and ": " in line)
    number = lambda key: float(said[key]) if key in said else float("nan")
    made_by = f"cvtdesign {version('cvtdesign')}"
    wrong = [f"{key} {said.get(key)!r}, expected {want!r}" for key, want in
             (("variant", p.layout.name), ("variant file", str(p.layout.file)), ("written by", made_by))
             if said.get(key) != want]
    for key, want in (("commanded gamma [deg]", np.degrees(p.gamma)), ("steering angle phi [deg]", np.degrees(p.phi))):
        if not abs(number(key) - want) < ANGLE_TOL:
            wrong.append(f"{key} {said.get(key)!r}, expected {want:.12g}")
    if head.get("originating_system") != made_by:
        wrong.append(f"originating system {head.get('originating_system')!r}, expected {made_by!r}")
    if head.get("name") != path.name:
        wrong.append(f"file name {head.get('name')!r}, expected {path.name!r}")
    return _row("header", not wrong, f"variant {said.get('variant')}, γ = {said.get('commanded gamma [deg]')}°, φ = "
                f"{number('steering angle phi [deg]'):.4f}°, {head.get('originating_system')}" if not wrong
                else "; ".join(wrong))


def _contact_row(shapes: dict, p: Plan) -> dict:
    """Every roller touches the sphere at R·n and does not cut into it."""
    k = kernel()
    R = mm(p.layout.sphere_radius)
    failed, worst = [], (0.0, 0.0, 0.0)
    for part in p.parts:
        if part.kind != "roller":
            continue
        d = k.DistShapeShape(shapes[part.name].wrapped, shapes["sphere"].wrapped)
        q = d.PointOnShape1(1)
        off = float(np.linalg.norm(np.array([q.X(), q.Y(), q.Z()]) - R * part.prims[0].normal))
        vol = _common_volume(shapes[part.name], shapes["sphere"])
        worst = tuple(max(w, x) for w, x in zip(worst, (d.Value(), off, vol)))
        if not (d.Value() < TOUCH_TOL and off < CONTACT_TOL and vol < VOLUME_TOL):
            failed.append(f"{part.name} (distance {d.Value():.3g} mm, {off:.3g} mm from R·n, overlap {vol:.3g} mm³)")
    return _row("rollers touch the sphere at R·n", not failed, f"largest distance {worst[0]:.1e} mm, offset from R·n "
                f"{worst[1]:.1e} mm, overlap {worst[2]:.1e} mm³" + (f"; failed: {failed}" if failed else ""))


def _fit_rows(shapes: dict, p: Plan) -> list[dict]:
    """No interference, attached parts touch, bounding box as computed from the layout."""
    boxes = {n: _bbox(s) for n, s in shapes.items()}
    kind = {part.name: part.kind for part in p.parts}
    pairs, largest = 0, (0.0, "")
    for a, b in itertools.combinations(shapes, 2):
        if {kind[a], kind[b]} == {"roller", "sphere"} or not boxes_overlap(boxes[a], boxes[b], 1.0):
            continue                  # the rollers' contact with the sphere is checked apart
        pairs += 1
        vol = _common_volume(shapes[a], shapes[b])
        if vol >= largest[0]:
            largest = (vol, f"{a}/{b}")
    rows = [_row("no interference", largest[0] < VOLUME_TOL, f"{pairs} pairs of parts near each other; largest "
                 f"intersection {largest[0]:.1e} mm³" + (f" ({largest[1]})" if largest[0] > 0 else ""))]
    joints = [tuple(t) for t in p.touching() if "sphere" not in t]
    loose = [f"{a}/{b}" for a, b in joints if shapes[a].distance(shapes[b]) >= TOUCH_TOL]
    rows.append(_row("attached parts touch", not loose, f"{len(joints)} fork–axle and coupling–axle joints"
                     + (f"; apart: {loose}" if loose else "")))
    exp = p.bbox()
    dev = float(np.max(np.abs(_bbox(kernel().cq.Compound.makeCompound(list(shapes.values()))) - exp)))
    size = exp[1] - exp[0]
    rows.append(_row("bounding box", dev < BBOX_TOL, f"{size[0]:.1f} × {size[1]:.1f} × {size[2]:.1f} mm; largest "
                     f"deviation from the layout's {dev:.1e} mm"))
    return rows


def check_step(path: Path, p: Plan) -> list[dict]:
    """Re-read the STEP file and check it against the layout's plan. Returns [{check, ok, detail}]:

    * names and count: the parts, in order, are the plan's (sphere, rollers, axles, forks, couplings, frame);
    * part names by role: `sphere`, `frame`, `<role>_<roller>` with the roller's role in the variant,
      `axle_<roller>`, `fork_<k>`, `coupling_<follower>`; no bare roller name;
    * one valid solid per part (BRepCheck_Analyzer) and each part in its planned colour;
    * header: FILE_DESCRIPTION names the variant, its file, the commanded γ and the steering angle φ (within
      ANGLE_TOL), and `cvtdesign <version>`, which is also FILE_NAME's originating system; FILE_NAME's
      name is the file's;
    * every roller touches the sphere at R·n: min distance < TOUCH_TOL, nearest point within CONTACT_TOL of
      R·n (n the model's contact normal at φ), intersection volume < VOLUME_TOL;
    * no interference: every two parts whose boxes (from the file) come within 1 mm intersect by less than
      VOLUME_TOL (wheels and their own axles included: the bore's clearance is real);
    * attached parts touch: each fork touches its axles, each coupling its two axles (distance < TOUCH_TOL);
    * bounding box: the file's equals the one computed from the layout's geometry within BBOX_TOL."""
    path = Path(path)
    parts = read_step(path)
    rows = _names_rows(parts, p) + [_header_row(path, p)]
    if not all(r["ok"] for r in rows if r["check"] in ("names and count", "one valid solid per part")):
        return rows
    shapes = {n: s for n, (s, _) in parts.items()}
    return rows + [_contact_row(shapes, p)] + _fit_rows(shapes, p)
