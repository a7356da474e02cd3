"""What every figure uses: matplotlib's parts (imported here only, the heavy optional import's boundary), the one
writer of a figure (output.write_file: atomically, umask's mode) and the placing of labels apart."""
from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np

from cvtdesign.io.output import write_file

PNG_COMPRESSION = 1     # zlib level of the PNG files: 40 % faster than the default 6, files 5 % larger


def figure_parts() -> SimpleNamespace:
    """The parts of matplotlib the figures use, imported here only (the heavy optional import's boundary):
    `figure(figsize=..., layout=...)` and `subplots(..., layout=...)` make Figures on Agg canvases; Line2D,
    Rectangle, Circle, Normalize and get_cmap as in pyplot; Bbox (matplotlib.transforms)."""
    from matplotlib import collections, colormaps, colors, lines, patches, transforms
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    def figure(**kw):
        fig = Figure(**kw)
        FigureCanvasAgg(fig)
        return fig

    def subplots(*args, figsize=None, layout=None, **kw):
        fig = figure(figsize=figsize, layout=layout)
        return fig, fig.subplots(*args, **kw)

    return SimpleNamespace(figure=figure, subplots=subplots, Line2D=lines.Line2D, Rectangle=patches.Rectangle,
                           Circle=patches.Circle, PatchCollection=collections.PatchCollection,
                           Normalize=colors.Normalize, get_cmap=colormaps.get_cmap, Bbox=transforms.Bbox)


def save(fig, path: Path, dpi=80):
    """Write a figure with output.write_file (matplotlib draws into the temporary file, which is then
    renamed onto `path`)."""
    path = Path(path)
    fmt = path.suffix[1:] or "png"
    extra = {"pil_kwargs": {"compress_level": PNG_COMPRESSION}} if fmt == "png" else {}
    write_file(path, lambda tmp: fig.savefig(tmp, dpi=dpi, format=fmt, **extra), kind="plot")


# where a label may go, in points from its anchor, tried in this order (`place_labels`)
OFFSETS = [(0, 0)] + [(dx, dy) for r in (1, 2, 3) for dx, dy in
                      ((0, 13 * r), (0, -13 * r), (34 * r, 0), (-34 * r, 0), (28 * r, 13 * r), (-28 * r, 13 * r),
                       (28 * r, -13 * r), (-28 * r, -13 * r))]

# beside a marker rather than on it (the Pareto points): (points right, up, the label's alignment to that spot)
# right, left, above, below, then farther
LABEL_BESIDE = [spot for r in (1.6, 3, 5) for spot in ((6 * r, 0, "left", "center"), (-6 * r, 0, "right", "center"),
                                                       (0, 7 * r, "center", "bottom"), (0, -7 * r, "center", "top"),
                                                       (6 * r, 7 * r, "left", "bottom"), (-6 * r, -7 * r, "right", "top"),
                                                       (6 * r, -7 * r, "left", "top"), (-6 * r, 7 * r, "right", "bottom"))]


def points_along(*polylines, per_segment=6) -> np.ndarray:
    """Points (n, 2) strewn along each polyline ((m, 2) data points; a segment with a non-finite end is
    skipped), per_segment a segment: a drawn line or arrow that labels keep off, handed to `place_labels`
    as its markers."""
    s = np.linspace(0, 1, per_segment + 1)[:-1, None]
    out = [np.empty((0, 2))]
    for xy in polylines:
        xy = np.asarray(xy, float).reshape(-1, 2)
        ok = np.all(np.isfinite(xy[:-1]), axis=1) & np.all(np.isfinite(xy[1:]), axis=1)
        out += [xy[k] + s * (xy[k + 1] - xy[k]) for k in np.flatnonzero(ok)]
        out += [xy[-1:]] if len(xy) and np.all(np.isfinite(xy[-1])) else []
    return np.vstack(out)


def place_labels(fig, ax, labels, fontsize=7, offsets=OFFSETS, markers=(), boxed=False, gap=0.0) -> int:
    """Write each label (anchor in data coordinates, or in 3-D for a 3-D axes; text; colour; alpha) at the
    first of `offsets` from its anchor (points, optionally with the label's alignment there; default OFFSETS,
    centred) where it overlaps no label already placed and stays inside the axes;
    a label with no such place is left out. Call it once the axes' limits and the figure's layout are
    final. `markers`: data points (n, 2) that no label may cover either; `boxed`: each label on a white box
    (over a picture); `gap`: pixels kept clear between two labels. Returns how many were left out."""
    renderer = fig.canvas.get_renderer()
    ax.apply_aspect()
    inside = ax.get_window_extent(renderer)
    placed = [t.get_window_extent(renderer) for t in ax.texts if t.get_text()]
    size = 6 * fig.dpi / 72                          # a marker's half-width [pixels]
    placed += [figure_parts().Bbox.from_extents(x - size, y - size, x + size, y + size)
               for x, y in ax.transData.transform(np.reshape(markers, (-1, 2)))] if len(markers) else []
    if hasattr(ax, "get_proj"):                      # a 3-D axes: its anchors projected onto its 2-D data plane
        proj = ax.get_proj()
        labels = [(tuple((proj @ np.append(p, 1.0))[:2] / (proj @ np.append(p, 1.0))[3]), *rest) for p, *rest in labels]
    left_out = 0
    for anchor, text, colour, alpha in labels:
        for dx, dy, *align in offsets:
            ha, va = align or ("center", "center")
            t = ax.annotate(text, xy=anchor, xytext=(dx, dy), textcoords="offset points", fontsize=fontsize,
                            ha=ha, va=va, color=colour, alpha=alpha, zorder=6, annotation_clip=False,
                            bbox={"fc": "white", "ec": "none", "alpha": 0.8, "pad": 1} if boxed else None)
            box = t.get_window_extent(renderer).expanded(1.04, 1.1).padded(gap)
            if (box.x0 >= inside.x0 and box.x1 <= inside.x1 and box.y0 >= inside.y0 and box.y1 <= inside.y1
                    and not any(box.overlaps(p) for p in placed)):
                placed.append(box)
                break
            t.remove()
        else:
            left_out += 1
    return left_out


