"""The CAD export's picture: the rendered assembly with a scale bar and a legend."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from cvtdesign.io.plots.base import figure_parts, place_labels, save


def scale_bar(width_mm: float) -> float:
    """A round length [mm] (1, 2 or 5 × a power of ten) near a fifth of `width_mm`, for a drawing's scale bar."""
    target = width_mm / 5
    base = 10 ** np.floor(np.log10(target))
    return float(max(m * base for m in (1, 2, 5) if m * base <= target))


def cad_picture(image, extent, caption: str, path, notes: dict):
    """A CAD assembly's shaded picture (an RGB array (rows, columns, 3), 8-bit or 0..1 floats, spanning
    `extent` (left, right, bottom, top) [mm] of the view plane, as cad.picture.raster draws it) with a
    caption above it, the parts named as in the STEP file, a scale bar and a legend below (`notes`: as
    cad.picture.annotations gives them), as PNG."""
    mpl = figure_parts()
    fig = mpl.figure(figsize=(8, 9.6))
    ax = fig.add_axes((0.02, 0.17, 0.96, 0.8))
    ax.imshow(image, interpolation="none", extent=extent)
    ax.axis("off")
    fig.text(0.5, 0.985, caption, ha="center", va="top", fontsize=10)
    x0, x1, y0, y1 = extent
    bar = scale_bar(x1 - x0)
    ax.plot([x0 + 0.03 * (x1 - x0), x0 + 0.03 * (x1 - x0) + bar], [y0 + 0.03 * (y1 - y0)] * 2, "k-", lw=3,
            solid_capstyle="butt")
    ax.text(x0 + 0.03 * (x1 - x0) + bar / 2, y0 + 0.045 * (y1 - y0), f"{bar:g} mm", ha="center", va="bottom",
            fontsize=9)
    place_labels(fig, ax, [(at, name, "k", 1.0) for name, at in notes["labels"]], fontsize=8, boxed=True)
    handles = [mpl.Rectangle((0, 0), 1, 1, fc=colour, ec="k", lw=0.5, label=text) for text, colour in notes["legend"]]
    fig.legend(handles=handles, loc="lower center", bbox_to_anchor=(0.5, 0.045), ncol=2, fontsize=8, frameon=False,
               title="parts, named as in the STEP file", title_fontsize=8)
    if notes["note"]:
        fig.text(0.5, 0.015, notes["note"], ha="center", va="bottom", fontsize=8, wrap=True)
    save(fig, Path(path), dpi=100)
