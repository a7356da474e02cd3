"""Drawings of the assembly for the reviewer: a hidden-line SVG (cadquery's SVG exporter) and a shaded
picture (`view_mesh` → `rasterise`, numpy only; `io.plots.cad_picture` captions and writes it as PNG),
both viewed along VIEW with z drawn upwards."""
from __future__ import annotations

from pathlib import Path

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


def write_svg(p: Plan, shapes: dict, path: Path, view=VIEW):
    """Hidden-line drawing by cadquery's SVG exporter, viewed along VIEW with z upwards."""
    k = kernel()
    # cadquery projects onto gp_Ax2(VIEW)'s own X/Y: turn the assembly about VIEW so that z comes out upwards
    ax = k.gp_Ax2(k.gp_Pnt(), k.gp_Dir(*view))
    y = np.array([ax.YDirection().X(), ax.YDirection().Y(), ax.YDirection().Z()])
    right, up, d = view_basis(view)
    turn = np.degrees(np.arctan2(np.cross(up, y) @ d, up @ y))
    compound = k.cq.Compound.makeCompound([shapes[n] for n in p.names()]).rotate((0, 0, 0), tuple(d), turn)
    svg = k.getSVG(compound, {"width": 900, "height": 900, "marginLeft": 30, "marginTop": 30, "showAxes": False,
                              "projectionDir": tuple(view), "showHidden": False, "strokeWidth": -1})
    Path(path).write_text(svg)


def view_mesh(p: Plan, shapes: dict, view=VIEW):
    """The front-facing triangles of every part in view coordinates along VIEW (z upwards), for `rasterise`:
    (triangles (T, 3, [right, up, towards viewer]) [mm], part index (T,), Lambert shade (T,))."""
    right, up, d = view_basis(view)
    light = unit(d + 0.6 * up + 0.3 * right)
    tris, ids, shades = [], [], []
    for i, part in enumerate(p.parts):
        verts, idx = shapes[part.name].tessellate(0.5, 0.4)             # [mm], [rad]
        verts, idx = np.array([v.toTuple() for v in verts]), np.array(idx)
        tri = verts[idx]
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])   # area-weighted, outward
        # smooth shading: average the normals at each vertex (cadquery does not share vertices between
        # faces, so edges between faces stay sharp)
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


def rasterise(tri, ids, shade, colours, pixels: int = 800):
    """Flat-shaded orthographic image by z-buffer (numpy only): every triangle marks the pixel centres
    inside it with its depth, each pixel keeps the nearest; dark outlines where the part under a pixel
    changes. colours: RGB per part index. Returns a (pixels, pixels, 3) RGB array, white background."""
    tri = np.array(tri, float)
    xy = tri[..., :2].reshape(-1, 2)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    tri[..., :2] = (tri[..., :2] - (lo + hi) / 2) * (0.94 * pixels / max(hi - lo)) + pixels / 2
    tri[..., 1] = pixels - tri[..., 1]                                  # image rows grow downwards
    # candidate pixels: each triangle's bounding box of pixel centres within the image, flattened
    start = np.clip(np.floor(tri[:, :, :2].min(axis=1) - 0.5).astype(int) + 1, 0, pixels)
    end = np.clip(np.floor(tri[:, :, :2].max(axis=1) - 0.5).astype(int) + 1, 0, pixels)
    size = np.maximum(end - start, 0)
    count = size[:, 0] * size[:, 1]
    # per triangle, its barycentric weights w0, w1 as affine functions a x + b y + c of the pixel centre
    (x0, x1, x2), (y0, y1, y2), (z0, z1, z2) = tri.transpose(2, 1, 0)
    det = (y1 - y2) * (x0 - x2) + (x2 - x1) * (y0 - y2)
    det = np.where(np.abs(det) < 1e-12, 1e-12, det)
    a0, b0, a1, b1 = (y1 - y2) / det, (x2 - x1) / det, (y2 - y0) / det, (x0 - x2) / det
    c0, c1 = -(a0 * x2 + b0 * y2), -(a1 * x2 + b1 * y2)
    t = np.repeat(np.arange(len(tri)), count)
    local = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    cx = start[t, 0] + local % size[t, 0] + 0.5
    cy = start[t, 1] + local // size[t, 0] + 0.5
    w0 = a0[t] * cx + b0[t] * cy + c0[t]
    w1 = a1[t] * cx + b1[t] * cy + c1[t]
    inside = (w0 >= 0) & (w1 >= 0) & (w0 + w1 <= 1)
    which, w0, w1 = t[inside], w0[inside], w1[inside]
    depth = z2[which] + w0 * (z0 - z2)[which] + w1 * (z1 - z2)[which]
    pix = cy[inside].astype(int) * pixels + cx[inside].astype(int)
    o = np.lexsort((-depth, pix))                                       # per pixel, nearest first
    first = o[np.r_[True, pix[o][1:] != pix[o][:-1]]]
    part = np.full(pixels * pixels, -1)
    part[pix[first]] = ids[which[first]]
    image = np.ones((pixels * pixels, 3))
    image[pix[first]] = np.asarray(colours)[ids[which[first]]] * shade[which[first]][:, None]
    part, image = part.reshape(pixels, pixels), image.reshape(pixels, pixels, 3)
    edge = np.zeros_like(part, dtype=bool)
    edge[1:, :] |= part[1:, :] != part[:-1, :]
    edge[:, 1:] |= part[:, 1:] != part[:, :-1]
    image[edge] *= 0.25
    return image


def picture_caption(p: Plan) -> str:
    return (f"{p.layout.name}: γ = {np.degrees(p.gamma):g}°, φ = {np.degrees(p.phi):.2f}°, {len(p.parts)} parts "
            f"(view along {VIEW}, z up)")
