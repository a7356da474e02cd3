"""CAD export for mechanical review (`cvtdesign export`): a variant's assembly at a commanded γ as a STEP
file (named, coloured parts; see `plan` for what each part is), an SVG line drawing and a shaded PNG, with
geometric checks of the written file (`checks.check_step`)."""
from __future__ import annotations

import time

import numpy as np

from cvtdesign.cad.checks import check_step
from cvtdesign.cad.picture import annotations, framed_svg, picture_caption, raster, svg_text, view_mesh
from cvtdesign.cad.plan import plan
from cvtdesign.cad.step import assembly, build, screen, step_header, write_step
from cvtdesign.core.checks import check_layout
from cvtdesign.core.layout import Layout
from cvtdesign.errors import InputError, RunError
from cvtdesign.io import plots
from cvtdesign.io.output import make_folder, staged


def _svg_result(svg: plots.Forked) -> str:
    """The SVG the forked process drew; what it raised is raised here, as one line (RunError) unless it is bad
    input."""
    ok, value = svg.answer()
    if ok:
        return value
    if isinstance(value, InputError):
        raise value
    if value is None:
        raise RunError("the drawing process ended unexpectedly")
    raise RunError(f"drawing the SVG failed: {plots.describe(value)}")


def export_variant(layout: Layout, out_dir="cad_out", gamma_deg: float = 45.0, check: bool = False,
                   stem: str | None = None) -> dict:
    """Export a layout's assembly at commanded γ [deg] as `<out_dir>/<stem>.step` (+ .svg, .png; `stem`
    defaults to the layout's name; the commands pass the variant file's stem, as files may share a `name:`).

    `layout`: a numeric `Layout` (the caller reads the variant file: io.variant.load_variant, whose checks
    this runs, `core.checks.check_layout`, so it need not). Impossible geometry raises InputError before
    anything is written; the three files appear together or not at all (`output.staged`). Three processes
    share the work once the parts are built: a forked copy of this one draws the SVG (cadquery's exact
    hidden lines, the longest step); this one renders the picture and writes the STEP file; a plotting
    process started at the outset (plots.Background, which imports matplotlib while cadquery is imported
    here) captions the picture and writes it as PNG. Returns {step, svg, png (paths), parts (names),
    gamma_deg, phi_deg, seconds (export time), and with `check`: checks ([{check, ok, detail}], see
    `checks.check_step`), check_seconds}."""
    t0 = time.perf_counter()
    painter = plots.Background()
    try:
        check_layout(layout)
        p = plan(layout, gamma_deg)
        shapes, pieces = build(p)
        screen(p, pieces)
        out = make_folder(out_dir, kind="CAD output folder")
        paths = [out / f"{stem or layout.name}.{ext}" for ext in ("step", "svg", "png")]
        with staged(paths, kind="CAD file") as tmps:     # the three files appear together or not at all
            # a forked copy of this process, with cadquery and the shapes already, draws the SVG on the other
            # core (OpenCascade holds the GIL, so a thread would not run beside this one)
            svg = plots.Forked(call=(svg_text, (p, shapes)))
            drawn = False
            try:
                image, part, extent = raster(*view_mesh(p, shapes), [part.colour for part in p.parts])
                notes = annotations(p, part, extent)
                painter.draw(plots.cad_picture, np.round(255 * image).astype(np.uint8), extent, picture_caption(p), tmps[2],
                             notes)
                drawn = True
                write_step(assembly(p, shapes), tmps[0], step_header(p, paths[0].name))
                tmps[1].write_text(framed_svg(_svg_result(svg), picture_caption(p), notes))
            finally:
                svg.close()
                # the painter writes through a temporary file of its own: let it finish, on a failure too,
                # so that nothing is left behind once `staged` removes the temporary files
                error = painter.wait() if drawn else None
            if error:
                raise RunError(f"PNG rendering failed: {error}")
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
