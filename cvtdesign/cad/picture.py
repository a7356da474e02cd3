"""Drawings of the assembly for the reviewer: a hidden-line SVG (cadquery's SVG exporter) and a shaded
picture (`view_mesh` → `rasterise`, numpy only; `io.plots.cad_picture` captions and writes it as PNG),
both viewed along VIEW with z drawn upwards."""
from __future__ import annotations

import numpy as np

from cvtdesign.cad.kernel import kernel
from cvtdesign.cad.plan import Plan
from cvtdesign.cad.shapes import unit

VIEW = (1.0, -0.3, 0.8)     # projection direction (towards the viewer) of the SVG and PNG, z drawn upwards


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
    compound = k.cq.Compound.makeCompound([shapes[n] for n in p.names()]).rotate((0, 0, 0), tuple(d), turn)
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
    """The front-facing triangles of every part in view coordinates along VIEW (z upwards), for `rasterise`:
    (triangles (T, 3, [right, up, towards viewer]) [mm], part index (T,), Lambert shade (T,))."""
    right, up, d = view_basis(view)
    light = unit(d + 0.6 * up + 0.3 * right)
    tris, ids, shades = [], [], []
    for i, part in enumerate(p.parts):
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


def rasterise(tri, ids, shade, colours, pixels: int = 800):
    """Flat-shaded orthographic image by z-buffer (numpy only): every triangle marks the pixel centres
    inside it (scanline spans) with its depth, each pixel keeps the nearest; dark outlines where the part
    under a pixel changes. colours: RGB per part index. Returns a (pixels, pixels, 3) RGB array, white
    background."""
    tri = np.array(tri, float)
    xy = tri[..., :2].reshape(-1, 2)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    tri[..., :2] = (tri[..., :2] - (lo + hi) / 2) * (0.94 * pixels / max(hi - lo)) + pixels / 2
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
    return image


def picture_caption(p: Plan) -> str:
    return (f"{p.layout.name}: γ = {np.degrees(p.gamma):g}°, φ = {np.degrees(p.phi):.2f}°, {len(p.parts)} parts "
            f"(view along {VIEW}, z up)")
