"""Drawings of the assembly for the reviewer: a line drawing as SVG (cadquery's exporter, framed by
`framed_svg`) and a shaded picture (`view_mesh` → `raster`, numpy only; `io.plots.cad_picture` writes it
as PNG), both viewed along VIEW with z drawn upwards, both with the parts named as in the STEP file, a scale
bar and a legend (`annotations`).

The coupling shafts of the STEP file (`coupling_<follower>`, a flexible shaft routed round the outside) are
left out of both drawings: the loops they make round the assembly puzzle the eye and say no more than the
legend's line 'A_ turns with A (shaft 1)'."""
from __future__ import annotations

import re
from xml.sax.saxutils import escape

import numpy as np

from cvtdesign.cad.kernel import kernel
from cvtdesign.cad.plan import COLOURS, Plan
from cvtdesign.cad.shapes import unit
from cvtdesign.io.plots import scale_bar

VIEW = (1.0, -0.3, 0.8)     # projection direction (towards the viewer) of the SVG and PNG, z drawn upwards
LABELLED = ("sphere", "roller", "fork", "frame")      # the kinds of part named in the drawings (axles: legend)
KIND_NAMES = {"sphere": "sphere", "drive": "drive roller: drive_<roller>", "follower": "follower roller: "
              "follower_<roller>", "steering": "steering roller: steering_<roller>", "axle": "axle: axle_<roller>",
              "fork": "fork: fork_<k> (steering.forks, from 1)", "frame": "mounting plate: frame"}


def view_basis(direction):
    """(right, up, towards viewer) unit vectors of an orthographic view along `direction`, z drawn upwards."""
    d = unit(direction)
    up = unit(np.array([0.0, 0.0, 1.0]) - d[2] * d)
    return np.cross(up, d), up, d


def svg_text(p: Plan, shapes: dict, view=VIEW) -> str:
    """Hidden-line drawing by cadquery's SVG exporter, viewed along VIEW with z upwards, as SVG text."""
    k = kernel()
    # cadquery projects onto gp_Ax2(VIEW)'s own X/Y: turn the assembly about VIEW so that z comes out upwards
    ax = k.gp_Ax2(k.gp_Pnt(), k.gp_Dir(*view))
    y = np.array([ax.YDirection().X(), ax.YDirection().Y(), ax.YDirection().Z()])
    right, up, d = view_basis(view)
    turn = np.degrees(np.arctan2(np.cross(up, y) @ d, up @ y))
    drawn = [part.name for part in p.parts if part.kind != "coupling"]
    compound = k.cq.Compound.makeCompound([shapes[n] for n in drawn]).rotate((0, 0, 0), tuple(d), turn)
    return k.getSVG(compound, {"width": 900, "height": 900, "marginLeft": 30, "marginTop": 30, "showAxes": False,
                               "projectionDir": tuple(view), "showHidden": False, "strokeWidth": -1})


def triangles(shape, tolerance=0.5, angular=0.4):
    """The shape's surface mesh (OpenCascade's, as cadquery's `tessellate` makes it): (vertices (V, 3) [mm],
    triangles (T, 3) of vertex indices, counter-clockwise seen from outside). tolerance [mm], angular [rad]."""
    k = kernel()
    shape.mesh(tolerance, angular)
    verts, tris, offset = [], [], 0
    for face in shape.Faces():
        loc = k.Location()
        poly = k.triangulation(face.wrapped, loc)
        if poly is None:
            continue
        trsf = loc.Transformation()
        m = np.array([[trsf.Value(r, c) for c in range(1, 5)] for r in range(1, 4)])
        nodes = np.array([poly.Node(i).Coord() for i in range(1, poly.NbNodes() + 1)])
        idx = np.array([poly.Triangle(i).Get() for i in range(1, poly.NbTriangles() + 1)]) - 1 + offset
        verts.append(nodes @ m[:, :3].T + m[:, 3])
        tris.append(idx[:, [0, 2, 1]] if face.wrapped.Orientation() == k.reversed else idx)
        offset += len(nodes)
    return np.concatenate(verts), np.concatenate(tris)


def view_mesh(p: Plan, shapes: dict, view=VIEW):
    """The front-facing triangles of every part but the couplings in view coordinates along VIEW (z upwards),
    for `raster`:
    (triangles (T, 3, [right, up, towards viewer]) [mm], part index (T,), Lambert shade (T,))."""
    right, up, d = view_basis(view)
    light = unit(d + 0.6 * up + 0.3 * right)
    tris, ids, shades = [], [], []
    for i, part in enumerate(p.parts):
        if part.kind == "coupling":          # not drawn (see the module's docstring)
            continue
        verts, idx = triangles(shapes[part.name])
        tri = verts[idx]
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])   # area-weighted, outward
        # smooth shading: average the normals at each vertex (the faces do not share vertices, so
        # edges between faces stay sharp)
        vn = np.zeros_like(verts)
        for k in range(3):
            np.add.at(vn, idx[:, k], normal)
        smooth = (vn / (np.linalg.norm(vn, axis=1, keepdims=True) + 1e-12))[idx].mean(axis=1)
        smooth /= np.linalg.norm(smooth, axis=1, keepdims=True) + 1e-12
        facing = normal @ d > 0                                          # back faces are hidden
        tris.append(tri[facing] @ np.array([right, up, d]).T)
        shades.append(0.35 + 0.65 * np.clip(smooth[facing] @ light, 0, 1))
        ids.append(np.full(int(facing.sum()), i))
    return np.concatenate(tris).astype(np.float32), np.concatenate(ids), np.concatenate(shades).astype(np.float32)


def _spans(tri, pixels: int):
    """Scanline spans of pixel centres inside each triangle (pixel coordinates, x right, y down): (triangle
    index, row, first column, number of columns) per span. On a row, each barycentric weight w_k = a_k x + b_k
    y + c_k ≥ 0 bounds x from below (a_k > 0) or above (a_k < 0). Also returns the weights' (a, b, c) (T, 3)."""
    (x0, x1, x2), (y0, y1, y2) = tri[..., 0].T, tri[..., 1].T
    det = (y1 - y2) * (x0 - x2) + (x2 - x1) * (y0 - y2)
    det = np.where(np.abs(det) < 1e-12, 1e-12, det)
    a0, b0, a1, b1 = (y1 - y2) / det, (x2 - x1) / det, (y2 - y0) / det, (x0 - x2) / det
    c0, c1 = -(a0 * x2 + b0 * y2), -(a1 * x2 + b1 * y2)
    a, b, c = (np.stack([u, v, -u - v + w], axis=1) for u, v, w in ((a0, a1, 0), (b0, b1, 0), (c0, c1, 1)))
    first = np.clip(np.ceil(tri[:, :, 1].min(axis=1) - 0.5).astype(int), 0, pixels)
    rows = np.maximum(np.clip(np.floor(tri[:, :, 1].max(axis=1) - 0.5).astype(int) + 1, 0, pixels) - first, 0)
    t = np.repeat(np.arange(len(tri)), rows)
    row = first[t] + np.arange(rows.sum()) - np.repeat(np.cumsum(rows) - rows, rows)
    rest = b[t] * (row + 0.5)[:, None] + c[t]
    at = a[t]
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = -rest / at
    left = np.max(np.where(at > 0, bound, -np.inf), axis=1)
    right = np.min(np.where(at < 0, bound, np.inf), axis=1)
    start = np.clip(np.ceil(left - 0.5), 0, pixels).astype(int)
    count = np.clip(np.floor(right - 0.5) + 1, 0, pixels).astype(int) - start
    count = np.where(np.all((at != 0) | (rest >= 0), axis=1), np.maximum(count, 0), 0)
    return (t, row, start, count), (a, b, c)


def raster(tri, ids, shade, colours, pixels: int = 800):
    """Flat-shaded orthographic image by z-buffer (numpy only): every triangle marks the pixel centres
    inside it (scanline spans) with its depth, each pixel keeps the nearest; dark outlines where the part
    under a pixel changes. colours: RGB per part index. Returns the image ((pixels, pixels, 3) RGB, white
    background), the part index under each pixel ((pixels, pixels), −1: background) and the image's extent
    in view coordinates [mm] (left, right, bottom, top), as matplotlib's imshow takes it."""
    tri = np.array(tri, float)
    xy = tri[..., :2].reshape(-1, 2)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    k, mid = 0.94 * pixels / max(hi - lo), (lo + hi) / 2          # pixels per mm, the picture's centre [mm]
    tri[..., :2] = (tri[..., :2] - mid) * k + pixels / 2
    tri[..., 1] = pixels - tri[..., 1]                                  # image rows grow downwards
    (t, row, start, count), (a, b, c) = _spans(tri, pixels)
    span = np.repeat(np.arange(len(t)), count)
    which, cy = t[span], row[span] + 0.5
    cx = start[span] + np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count) + 0.5
    w0 = a[which, 0] * cx + b[which, 0] * cy + c[which, 0]
    w1 = a[which, 1] * cx + b[which, 1] * cy + c[which, 1]
    z = tri[:, :, 2]
    depth = z[which, 2] + w0 * (z[which, 0] - z[which, 2]) + w1 * (z[which, 1] - z[which, 2])
    pix = row[span] * pixels + cx.astype(int)
    # z-buffer in one pass: per pixel the largest key, the depth scaled to 38 bits above the triangle's index
    scaled = np.round((depth - depth.min()) / max(np.ptp(depth), 1e-12) * (2 ** 38 - 1)).astype(np.int64)
    key = np.full(pixels * pixels, -1, dtype=np.int64)
    np.maximum.at(key, pix, (scaled << 24) | which)
    hit = key >= 0
    top = key[hit] & (2 ** 24 - 1)
    part = np.full(pixels * pixels, -1)
    part[hit] = ids[top]
    image = np.ones((pixels * pixels, 3))
    image[hit] = np.asarray(colours)[ids[top]] * shade[top][:, None]
    part, image = part.reshape(pixels, pixels), image.reshape(pixels, pixels, 3)
    edge = np.zeros_like(part, dtype=bool)
    edge[1:, :] |= part[1:, :] != part[:-1, :]
    edge[:, 1:] |= part[:, 1:] != part[:, :-1]
    image[edge] *= 0.25
    half = pixels / 2 / k
    return image, part, (mid[0] - half, mid[0] + half, mid[1] - half, mid[1] + half)


def annotations(p: Plan, part, extent) -> dict:
    """What both drawings add to the parts: {'labels': [(part name, (x, y) [mm] in view coordinates)], a
    visible point of each named part (LABELLED), nearest the middle of what is seen of it; 'legend': [(text,
    RGB)] of the kinds of part drawn; 'note': which rollers the undrawn couplings join}. part, extent: as
    `raster` returns them."""
    rows, cols = part.shape
    labels = []
    for i, prt in enumerate(p.parts):
        seen = np.argwhere(part == i)
        if prt.kind not in LABELLED or not len(seen):
            continue
        r, c = seen[np.argmin(np.sum((seen - seen.mean(axis=0)) ** 2, axis=1))] + 0.5
        x0, x1, y0, y1 = extent
        labels.append((prt.name, (x0 + (x1 - x0) * c / cols, y1 - (y1 - y0) * r / rows)))
    kinds = dict.fromkeys((prt.name.split("_")[0] if prt.kind == "roller" else prt.kind) for prt in p.parts
                          if prt.kind != "coupling")
    legend = [(KIND_NAMES[k], COLOURS[k]) for k in kinds]
    roles = {r.name: r for r in p.layout.rollers}
    joined = [f"{f} turns with {d.name} (shaft {roles[f].shaft})" for f in
              (prt.name.partition("_")[2] for prt in p.parts if prt.kind == "coupling")
              for d in p.layout.rollers if d.role == "drive" and d.shaft == roles[f].shaft]
    note = ("couplings not drawn (in the STEP file as coupling_<follower>): " + "; ".join(joined)) if joined else ""
    return {"labels": labels, "legend": legend, "note": note}


def picture_caption(p: Plan) -> str:
    return (f"{p.layout.name}: γ = {np.degrees(p.gamma):g}°, φ = {np.degrees(p.phi):.2f}°, {len(p.parts)} parts "
            f"(view along {VIEW}, z up)")


SVG_SIZE = 900          # [px] the drawing's square; the legend goes below it
SVG_FONT = 11           # [px]


def _svg_labels(labels, at) -> list[str]:
    """Each label as SVG text at the first spot near its anchor where its (estimated) box overlaps no label
    placed before it (at: view coordinates [mm] → SVG pixels)."""
    placed, out = [], []
    spots = [(0, 0)] + [(dx, dy) for r in (1, 2, 3) for dx, dy in ((0, -14 * r), (0, 14 * r), (40 * r, 0), (-40 * r, 0))]
    for name, anchor in labels:
        w, h = 0.62 * SVG_FONT * len(name), 1.25 * SVG_FONT
        x, y = at(anchor)
        for dx, dy in spots:
            box = (x + dx - w / 2, y + dy - h / 2, x + dx + w / 2, y + dy + h / 2)
            if not any(box[0] < b[2] and b[0] < box[2] and box[1] < b[3] and b[1] < box[3] for b in placed):
                break
        placed.append(box)
        out.append(f'<text x="{x + dx:.1f}" y="{y + dy + 0.35 * SVG_FONT:.1f}" text-anchor="middle" '
                   f'font-size="{SVG_FONT}" stroke="white" stroke-width="3" paint-order="stroke">{escape(name)}</text>')
    return out


def framed_svg(raw: str, caption: str, ann: dict) -> str:
    """cadquery's line drawing (`svg_text`) centred in a SVG_SIZE square, without its empty hidden-line
    group, with the caption above, the parts' names (`annotations`), a scale bar and a legend below.
    The drawing's lines keep cadquery's own coordinates (view coordinates [mm], y up), under one transform."""
    paths = raw.split("<!-- solid lines -->")[1]
    paths = paths[paths.index(">") + 1: paths.rindex("</g>")]
    paths = paths[: paths.rindex("</g>")].strip()
    xy = np.array(re.findall(r"[ML]\s*(-?[\d.]+(?:e-?\d+)?),(-?[\d.]+(?:e-?\d+)?)", paths), float)
    (x0, y0), (x1, y1) = xy.min(axis=0), xy.max(axis=0)
    k = 0.88 * SVG_SIZE / max(x1 - x0, y1 - y0)                      # px per mm
    cx, cy, top = (x0 + x1) / 2, (y0 + y1) / 2, 40
    at = lambda p: (SVG_SIZE / 2 + k * (p[0] - cx), top + SVG_SIZE / 2 - k * (p[1] - cy))
    bar = scale_bar(SVG_SIZE / k)
    lines = ["parts named as in the STEP file:"] + [name for name, _ in ann["legend"]] + \
        ([ann["note"]] if ann["note"] else [])
    height = top + SVG_SIZE + 30 + 16 * len(lines)
    bx, by = 30, top + SVG_SIZE + 5
    out = ['<?xml version="1.0" encoding="UTF-8" standalone="no"?>',
           f'<svg xmlns="http://www.w3.org/2000/svg" width="{SVG_SIZE}" height="{height}" '
           f'viewBox="0 0 {SVG_SIZE} {height}" font-family="sans-serif">',
           f'<text x="{SVG_SIZE / 2}" y="24" text-anchor="middle" font-size="14">{escape(caption)}</text>',
           f'<g transform="translate({SVG_SIZE / 2 - k * cx:.4f},{top + SVG_SIZE / 2 + k * cy:.4f}) scale({k:.6f},'
           f'{-k:.6f})" stroke="rgb(0,0,0)" stroke-width="{1 / k:.5f}" fill="none">',
           "<!-- solid lines -->", paths, "</g>", *_svg_labels(ann["labels"], at),
           f'<path d="M{bx},{by} h{k * bar:.2f} M{bx},{by - 5} v10 M{bx + k * bar:.2f},{by - 5} v10" stroke="black" '
           f'stroke-width="2"/>', f'<text x="{bx + k * bar / 2:.2f}" y="{by - 8}" text-anchor="middle" '
           f'font-size="{SVG_FONT}">{bar:g} mm</text>']
    out += [f'<text x="{bx}" y="{by + 26 + 16 * i}" font-size="{SVG_FONT}">{escape(t)}</text>' for i, t in enumerate(lines)]
    return "\n".join(out) + "\n</svg>\n"
