"""CAD export for mechanical review (`cvtdesign export`): a variant's assembly at a commanded γ as a STEP
file (named, coloured parts; see `plan` for what each part is), an SVG line drawing and a shaded PNG, with
geometric checks of the written file (`checks.check_step`)."""
from __future__ import annotations

import threading
import time

import numpy as np

from cvtdesign.cad.checks import check_step
from cvtdesign.cad.picture import picture_caption, rasterise, view_mesh, write_svg
from cvtdesign.cad.plan import plan
from cvtdesign.cad.step import assembly, build, screen, step_header, write_step
from cvtdesign.core.checks import check_layout
from cvtdesign.core.layout import Layout
from cvtdesign.io import plots
from cvtdesign.io.output import make_folder, staged
from cvtdesign.io.variant import load_variant


class _Picture(threading.Thread):
    """The shaded picture, rasterised beside the main thread (numpy releases the GIL in its array work):
    `image` as 8-bit RGB, or `error`."""

    def __init__(self, mesh, colours):
        super().__init__(daemon=True)
        self.mesh, self.colours, self.image, self.error = mesh, colours, None, None

    def run(self):
        try:
            self.image = np.round(255 * rasterise(*self.mesh, self.colours)).astype(np.uint8)
        except Exception as e:      # raised again by the main thread
            self.error = e


def export_variant(layout_or_path, out_dir="cad_out", gamma_deg: float = 45.0, check: bool = False) -> dict:
    """Export a variant's assembly at commanded γ [deg] as `<out_dir>/<name>.step` (+ .svg, .png).

    `layout_or_path`: a numeric `Layout` or a variant file. Impossible geometry raises InputError before
    anything is written; the three files appear together or not at all (`output.staged`). The picture is
    rasterised here while the STEP and SVG files are written, then captioned and written as PNG by a
    second process (plots.Background, which imports matplotlib while cadquery is imported here). Returns
    {step, svg, png (paths), parts (names), gamma_deg, phi_deg, seconds (export time), and with `check`:
    checks ([{check, ok, detail}], see `checks.check_step`), check_seconds}."""
    t0 = time.perf_counter()
    painter = plots.Background()
    try:
        if isinstance(layout_or_path, Layout):
            layout = layout_or_path
            check_layout(layout)
        else:
            layout = load_variant(layout_or_path)
        p = plan(layout, gamma_deg)
        shapes, pieces = build(p)
        screen(p, pieces)
        out = make_folder(out_dir, kind="CAD output folder")
        paths = [out / f"{layout.name}.{ext}" for ext in ("step", "svg", "png")]
        picture = _Picture(view_mesh(p, shapes), [part.colour for part in p.parts])
        picture.start()
        with staged(paths, kind="CAD file") as tmps:     # the three files appear together or not at all
            write_step(assembly(p, shapes), tmps[0], step_header(p, paths[0].name))
            write_svg(p, shapes, tmps[1])
            picture.join()
            if picture.error is not None:
                raise picture.error
            painter.draw("cad_picture", picture.image, picture_caption(p), tmps[2])
            error = painter.wait()
            if error:
                raise RuntimeError(f"PNG rendering failed: {error}")
    finally:
        painter.close()
    result = {"step": str(paths[0]), "svg": str(paths[1]), "png": str(paths[2]), "parts": p.names(),
              "gamma_deg": float(gamma_deg), "phi_deg": float(np.degrees(p.phi)),
              "seconds": time.perf_counter() - t0}
    if check:
        t1 = time.perf_counter()
        result["checks"] = check_step(paths[0], p)
        result["check_seconds"] = time.perf_counter() - t1
    return result
