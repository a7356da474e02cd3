"""Matplotlib figures, drawn on Agg canvases without pyplot (no figure manager, no GUI backend), written as
PNG by output.write_file (atomically, umask's mode)."""
from __future__ import annotations

import gc
import multiprocessing
import os
import signal
import zlib
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from cvtdesign.io.output import OutputError, write_file

PNG_COMPRESSION = 1     # zlib level of the PNG files: 40 % faster than the default 6, files 5 % larger


def _mpl():
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


def figure_parts() -> SimpleNamespace:
    """The parts of matplotlib that figures drawn in other modules use (io.layout_drawing): see `_mpl`."""
    return _mpl()


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


def place_labels(fig, ax, labels, fontsize=7, offsets=OFFSETS, markers=(), boxed=False) -> int:
    """Write each label (anchor in data coordinates, or in 3-D for a 3-D axes; text; colour; alpha) at the
    first of `offsets` from its anchor (points, optionally with the label's alignment there; default OFFSETS,
    centred) where it overlaps no label already placed and stays inside the axes;
    a label with no such place is left out. Call it once the axes' limits and the figure's layout are
    final. `markers`: data points (n, 2) that no label may cover either; `boxed`: each label on a white box
    (over a picture). Returns how many were left out."""
    renderer = fig.canvas.get_renderer()
    ax.apply_aspect()
    inside = ax.get_window_extent(renderer)
    placed = [t.get_window_extent(renderer) for t in ax.texts if t.get_text()]
    size = 6 * fig.dpi / 72                          # a marker's half-width [pixels]
    placed += [_mpl().Bbox.from_extents(x - size, y - size, x + size, y + size)
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
            box = t.get_window_extent(renderer).expanded(1.04, 1.1)
            if (box.x0 >= inside.x0 and box.x1 <= inside.x1 and box.y0 >= inside.y0 and box.y1 <= inside.y1
                    and not any(box.overlaps(p) for p in placed)):
                placed.append(box)
                break
            t.remove()
        else:
            left_out += 1
    return left_out


COMPARE_ROWS = (("alpha", "slip angle α [°]", np.degrees),
                ("alpha_steering", "steering part γ_axis − γ_cmd [°]", np.degrees),
                ("alpha_drive", "drive part α − (γ_axis − γ_cmd) [°]", np.degrees),
                ("efficiency", "efficiency P_out/P_in [-]", lambda x: x))
LOAD_STYLES = ("-", "--", ":", "-.")
LOAD_MARKERS = ("o", "s", "^", "v")
FLAGS = ((1, "+", "grey", "not converged"), (2, "x", "k", "lost contact"), (3, "x", "r", "gross slip"),
         (4, "v", "m", "reversed (sphere turning backwards)"), (5, "d", "c", "two roots (history-dependent)"))
COMPARE_KEYS = ("gamma_cmd", "load", "status", *(key for key, _, _ in COMPARE_ROWS))   # what compare_figure reads
# the compare panels' titles sit on the axes' top edge, where matplotlib would place them after measuring the
# (absent) top ticks: given, that measuring pass (a twentieth of the drawing) is skipped
TITLE_Y = 1.0
# a variant's colour is the same in every run: Kim's existing CVT and the ideal CVT always these, every other
# variant the PALETTE colour its name hashes to (`variant_colours`)
# (the shipped variants and the shipped studies' optima hash to different colours: box red, box_kalker green,
# existing_kalker purple, unequal pink, box_box_placement orange, box_box_placement_kalker brown)
EXISTING_COLOUR, IDEAL_COLOUR = "#1f77b4", "#000000"
PALETTE = ("#ff7f0e", "#8c564b", "#9467bd", "#d62728", "#bcbd22", "#2ca02c", "#e377c2", "#17becf")
OVERLAY_MAX = 3     # up to this many variants are overlaid in each panel; more get a column each
PANELS_MAX = 6      # at most this many columns of variants; the others are in the table only


def variant_colours(names) -> dict:
    """{name: colour} that does not depend on the order of the variants or on the run: 'existing' (Kim's CVT)
    EXISTING_COLOUR; every other the PALETTE colour its name hashes to (CRC-32 of 'cvtdesign <name>', the same
    in every process), or, when a variant of the same run took that colour, the next free one, the names
    taken in sorted order (so only two variants hashing alike, in one run, make one of them change colour)."""
    out, taken = {}, set()
    for name in sorted(set(names)):
        if name == "existing":
            out[name] = EXISTING_COLOUR
            continue
        k = zlib.crc32(f"cvtdesign {name}".encode())
        free = [PALETTE[(k + i) % len(PALETTE)] for i in range(len(PALETTE))
                if PALETTE[(k + i) % len(PALETTE)] not in taken] or [PALETTE[k % len(PALETTE)]]
        out[name] = free[0]
        taken.add(free[0])
    return out


def shown_variants(results) -> tuple[list, str]:
    """The variants the figure draws, in the given order, and a note of those it leaves to the table: all
    of them up to PANELS_MAX; beyond, 'existing' and those with the smallest worst |α| over their ok points."""
    if len(results) <= PANELS_MAX:
        return list(results), ""
    ok = {name: np.abs(res["alpha"][res["status"] == 0]) for name, res in results}
    worst = {name: float(np.nanmax(a)) if np.isfinite(a).any() else np.inf for name, a in ok.items()}
    keep = sorted(worst, key=lambda n: (n != "existing", worst[n]))[:PANELS_MAX]
    return ([(n, r) for n, r in results if n in keep],
            f"{PANELS_MAX} of {len(results)} variants drawn (existing and the smallest worst |α|); the table has all")


def _loads(results, loads):
    """The loads drawn [N m], each the first variant's grid load nearest a requested one, with their line
    style and marker by |load| rank: [(load, style, marker)], largest |load| first."""
    grid = results[0][1]["load"][0]
    loads = sorted({round(float(grid[np.argmin(np.abs(grid - L))]), 9) for L in loads})
    ranked = sorted({abs(L) for L in loads}, reverse=True)
    style = {a: (LOAD_STYLES[k % 4], LOAD_MARKERS[k % 4]) for k, a in enumerate(ranked)}
    return [(L, *style[abs(L)]) for L in sorted(loads, key=lambda L: (-abs(L), L))]


def _panels(results, loads, colours):
    """The line panels of a row: [(title, [(name, result, colour)], [(load, style, marker)])]. Up to
    OVERLAY_MAX variants: every variant overlaid, the loads below zero in one panel, the others in a
    second; more: one panel per variant with all its loads (small multiples)."""
    drawn = _loads(results, loads)
    every = [(name, res, colours[name]) for name, res in results]
    if len(results) <= OVERLAY_MAX:
        cols = [("τ⊥ < 0", [x for x in drawn if x[0] < 0]), ("τ⊥ ≥ 0", [x for x in drawn if x[0] >= 0])]
        return [(title, every, col) for title, col in cols if col]
    return [(name, [(name, res, colour)], drawn) for name, res, colour in every]


def _curve(res, key, conv, L):
    """(γ [deg], the quantity at the grid load nearest L [N m], the points' status there)."""
    j = int(np.argmin(np.abs(res["load"][0] - L)))
    return np.degrees(res["gamma_cmd"][:, j]), conv(res[key][:, j]), res["status"][:, j]


def _row_limits(panels, key, conv, reference):
    """Shared y-limits of a row: every curve it draws and the ideal CVT's reference, with 6 % margins."""
    vals = [reference] + [v for _, variants, col in panels for _, res, _ in variants for L, _, _ in col
                          for v in _curve(res, key, conv, L)[1]]
    vals = np.asarray(vals, float)
    lo, hi = float(np.nanmin(vals)), float(np.nanmax(vals))
    pad = 0.06 * (hi - lo or 1.0)
    return lo - pad, hi + pad


def _line_row(axes, row, panels, first_row: bool, overlay: bool):
    """One quantity against commanded γ, a panel per entry of `panels` (see `_panels`), the ideal CVT as
    reference, left-out points marked at the panel's foot; every panel on the row's y-scale, which it returns."""
    key, label, conv = row
    reference = 1.0 if key == "efficiency" else 0.0
    lo, hi = _row_limits(panels, key, conv, reference)
    for c, (ax, (title, variants, col)) in enumerate(zip(axes, panels)):
        ax.axhline(reference, color=IDEAL_COLOUR, lw=1.5, zorder=1)
        for name, res, colour in variants:
            for L, ls, marker in col:
                g, y, status = _curve(res, key, conv, L)
                ax.plot(g, y, ls=ls, marker=marker, ms=3, color=colour, lw=1.2)
                band = _curve(res, f"{key}_band", conv, L)[1] if f"{key}_band" in res else np.nan
                if np.isfinite(band).any():        # the 95 % interval from the calibration's uncertainty
                    ax.fill_between(g, y - band, y + band, color=colour, alpha=0.18, lw=0)
                bad = status != 0
                if bad.any():
                    ax.plot(g[bad], np.full(bad.sum(), lo + 0.03 * (hi - lo)), "x", color=colour, ms=6, mew=1.5)
        ax.set_ylim(lo, hi)
        if overlay:
            ax.set_title(f"{label.split(' [')[0]}, {title}", fontsize=9, y=TITLE_Y)
        elif first_row:
            ax.set_title(title, fontsize=10, y=TITLE_Y, color=variants[0][2], fontweight="bold")
        ax.set_xlabel("commanded γ [°]", fontsize=8)
        if overlay or c == 0:
            ax.set_ylabel(label, fontsize=8)
        else:
            ax.tick_params(labelleft=False)
        ax.tick_params(labelsize=8)
        ax.grid(alpha=0.3)
    return lo, hi


def _efficiency_map(ax, name, res, norm, mpl):
    """Efficiency over γ × τ⊥ for one variant on the shared colour scale `norm`; where no power enters (τ⊥ = 0,
    efficiency undefined) the cell is hatched grey; points that left the physics marked (how many: returned
    with the colour mesh)."""
    g, t, eff = np.degrees(res["gamma_cmd"]), res["load"], res["efficiency"]
    ax.set_facecolor("white")
    idle = (res["status"] == 0) & ~np.isfinite(eff)
    dg = np.min(np.diff(g[:, 0])) / 2 if g.shape[0] > 1 else 1.0
    dt = np.min(np.diff(t[0])) / 2 if t.shape[1] > 1 else 0.05
    cells = [mpl.Rectangle((gi - dg, ti - dt), 2 * dg, 2 * dt) for gi, ti in zip(g[idle], t[idle])]
    ax.add_collection(mpl.PatchCollection(cells, fc="lightgrey", ec="grey", hatch="///", lw=0, zorder=0))
    pc = ax.pcolormesh(g, t, np.ma.masked_invalid(eff), cmap="viridis", norm=norm, shading="nearest", zorder=1)
    marked = 0
    for code, marker, colour, label in FLAGS:
        bad = res["status"] == code
        if bad.any():
            marked += len(ax.plot(g[bad], t[bad], marker, color=colour, ms=5, ls="none", zorder=2)[0].get_xdata())
    ax.set_title(f"{name}: efficiency", fontsize=9, y=TITLE_Y)
    ax.set_xlabel("commanded γ [°]", fontsize=8)
    ax.set_ylabel("τ⊥ [N·m]", fontsize=8)
    ax.tick_params(labelsize=8)
    return pc, marked


def _compare_legend(fig, shown, loads, colours, mpl, top: float) -> float:
    """The legend, inside the canvas below `top` (figure fraction): in as many columns as fit its width.
    Returns the figure fraction of its foot."""
    handles = [mpl.Line2D([], [], color=colours[name], lw=2.5, label=name + (
        " — THEORY ONLY (uncalibrated: likely too stiff)" if res.get("theory_only") else "")) for name, res in shown]
    if any(np.isfinite(res.get("alpha_band", np.nan)).any() for _, res in shown):
        handles.append(mpl.Rectangle((0, 0), 1, 1, fc="dimgrey", alpha=0.18, lw=0,
                                     label="shaded: 95 % interval from the calibration's uncertainty"))
    handles.append(mpl.Line2D([], [], color=IDEAL_COLOUR, lw=1.5, label="ideal CVT (α = 0, efficiency 1)"))
    for L, ls, marker in sorted(_loads(shown, loads), key=lambda x: x[0]):
        handles.append(mpl.Line2D([], [], color="dimgrey", ls=ls, marker=marker, ms=4, label=f"τ⊥ = {L:+g} N·m"))
    handles.append(mpl.Line2D([], [], color="dimgrey", marker="x", ls="none", label="left out (status ≠ ok), at "
                              "the panel's foot"))
    handles.append(mpl.Rectangle((0, 0), 1, 1, fc="lightgrey", ec="grey", hatch="///",
                                 label="no power transmitted (τ⊥ = 0: efficiency undefined)"))
    handles += [mpl.Line2D([], [], marker=m, color=c, ls="none", label=lab) for _, m, c, lab in FLAGS]
    renderer = fig.canvas.get_renderer()
    for ncol in range(6, 0, -1):
        legend = fig.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, top), ncol=ncol, fontsize=8,
                            frameon=False)
        box = legend.get_window_extent(renderer)
        if box.width <= 0.98 * fig.bbox.width or ncol == 1:
            return box.y0 / fig.bbox.height
        legend.remove()


def compare_figure(results: list[tuple[str, dict]], path: Path, loads=(-1.0, -0.5, 0.5, 1.0)) -> dict:
    """The variants side by side (Kim Figs 20-21): one row per quantity (α, its steering part γ_axis − γ_cmd,
    its drive part, efficiency) against commanded γ, every panel of a row on one y-scale, the ideal CVT
    (α = 0, efficiency 1) drawn as reference; then each variant's efficiency map over γ × τ⊥ on one shared
    colour scale, with the cells that transmit no power (τ⊥ = 0) hatched and the points where the physics
    stops holding marked. Up to OVERLAY_MAX variants are overlaid (colour per variant, line style and marker
    per load τ⊥, negative and positive loads in two columns); more get a column each (small multiples), at
    most PANELS_MAX (`shown_variants`). Each variant has its colour of `variant_colours`, whatever the
    order. A variant's result may carry '<quantity>_band' (the half-width of its 95 % interval at each point,
    core.uncertainty.point_bands), drawn shaded around its curves, and 'theory_only', said in the legend.
    Returns {'ylim': {quantity: [(lo, hi) per panel]}, 'clim': (lo, hi) of the maps, 'marked': [flagged
    points marked on each drawn variant's map], 'shown': [names drawn], 'colours': {name: colour}, 'legend':
    [its labels], 'bands': the shaded bands drawn}."""
    mpl = _mpl()
    shown, note = shown_variants(results)
    colours = variant_colours(name for name, _ in results)
    panels = _panels(shown, loads, colours)
    overlay = len(shown) <= OVERLAY_MAX
    fig = mpl.figure(figsize=(12, 17) if overlay else (max(12.0, 2.9 * len(shown) + 1.5), 17))
    fig.suptitle("variants over their envelope: slip angle α, its steering and drive parts and efficiency against "
                 "commanded γ (Kim Figs 20-21)" + (f"\n{note}" if note else ""), fontsize=12, y=0.995, va="top")
    title_foot = 1 - (0.03 if note else 0.018)
    top = _compare_legend(fig, shown, loads, colours, mpl, title_foot) - (0.02 if overlay else 0.03)
    grid = fig.add_gridspec(5, 1, height_ratios=(1, 1, 1, 1, 1.25), top=top, bottom=0.035, left=0.07, right=0.95,
                            hspace=0.42)
    limits = {"ylim": {}, "shown": [name for name, _ in shown], "colours": colours}
    for k, row in enumerate(COMPARE_ROWS):
        sub = grid[k].subgridspec(1, len(panels), wspace=0.18 if overlay else 0.06)
        axes = [fig.add_subplot(sub[0, c]) for c in range(len(panels))]
        _line_row(axes, row, panels, k == 0, overlay)
        limits["ylim"][row[0]] = [ax.get_ylim() for ax in axes]
    effs = np.concatenate([res["efficiency"].ravel() for _, res in shown])
    lo = float(np.nanmin(effs)) if np.isfinite(effs).any() else 0.0
    norm = mpl.Normalize(vmin=min(np.floor(lo * 20) / 20, 0.95), vmax=1.0)
    sub = grid[4].subgridspec(1, len(shown), wspace=0.45)
    maps = [fig.add_subplot(sub[0, c]) for c in range(len(shown))]
    limits["marked"] = []
    for ax, (name, res) in zip(maps, shown):
        pc, marked = _efficiency_map(ax, name, res, norm, mpl)
        limits["marked"].append(marked)
    fig.colorbar(pc, ax=maps, label="efficiency P_out/P_in [-] (one scale for all)")
    limits["clim"] = (norm.vmin, norm.vmax)
    limits["legend"] = [t.get_text() for t in fig.legends[0].get_texts()]
    limits["bands"] = sum(len(ax.collections) for ax in fig.axes[:len(COMPARE_ROWS) * len(panels)])
    save(fig, path)
    return limits


def worker(conn, parent_end):
    """Plotting process: imports matplotlib at once (while the parent computes), then draws what it is
    sent, (figure function name, args), and answers None or an error text. Interrupted (Background.close),
    it stops quietly: output.write_file has removed the file it was writing.

    It draws one figure and ends, so Python's cyclic garbage collector stays off: its passes would walk
    matplotlib's objects and the parent's (about a seventh of the process's time) for cycles that the end of
    the process frees anyway; the memory it uses stays the same."""
    gc.disable()
    parent_end.close()      # its copy of the parent's end: without it, a parent that dies would not be noticed
    failed = None
    try:
        _mpl()
    except KeyboardInterrupt:
        return
    except Exception as e:  # noqa: BLE001 — reported to the parent with its request, unless interrupted
        if _interrupted(e):
            return
        failed = f"{type(e).__name__}: {e}"
    try:
        name, args = conn.recv()
        if failed:
            conn.send(failed)
            return
        globals()[name](*args)
        conn.send(None)
    except (EOFError, BrokenPipeError, KeyboardInterrupt):
        return
    except OutputError as e:  # raised again by the parent (Background.wait): one line, exit status 2
        conn.send(e)
    except Exception as e:  # noqa: BLE001 — reported by the parent as one line, unless interrupted
        if not _interrupted(e):
            conn.send(f"{type(e).__name__}: {e}")


def _interrupted(e: BaseException) -> bool:
    """Whether `e` comes of Background.close's interrupt: a KeyboardInterrupt inside C code (an extension
    module being imported, say) surfaces as another exception caused by it, and its traceback on stderr would
    follow the parent's one-line error."""
    while e is not None:
        if isinstance(e, KeyboardInterrupt):
            return True
        e = e.__cause__ or e.__context__
    return False


class Background:
    """Run figure functions of this module in a forked process that has matplotlib ready.

    Start it before the computation; `draw` hands over the data; `wait` returns the error text or None
    (a file that could not be written is raised as the OutputError it was); `close` ends the process if it
    still runs, without leaving a half-written file."""

    def __init__(self):
        ctx = multiprocessing.get_context("fork")
        self.conn, child = ctx.Pipe()
        self.proc = ctx.Process(target=worker, args=(child, self.conn), daemon=True)
        self.proc.start()
        child.close()

    def draw(self, name, *args):
        self.conn.send((name, args))

    def wait(self):
        try:
            answer = self.conn.recv()
        except EOFError:
            return "the plotting process ended unexpectedly"
        finally:
            self.close()
        if isinstance(answer, OutputError):
            raise answer
        return answer

    def close(self):
        """After an answer the process ends by itself; otherwise (the parent failed) it is interrupted, so a
        file it is writing is removed (output.write_file), and ended if it does not stop."""
        self.proc.join(timeout=0.1)
        if self.proc.is_alive():
            os.kill(self.proc.pid, signal.SIGINT)
            self.proc.join(timeout=5)
        if self.proc.is_alive():
            self.proc.terminate()
            self.proc.join()
        self.conn.close()


def pareto_figure(chains: list[tuple[str, list[dict], int]], path: Path):
    """Slip/efficiency Pareto fronts (worst |α| [deg] against mean power loss [W]), knee marked, every point
    labelled with its design (its 'label', e.g. 'preload = 121.9 N, d = 48.8 mm'), the labels placed apart.
    chains: (label, points with worst_alpha_deg, power_loss_W, label, success, point), index of the knee
    point)."""
    mpl = _mpl()
    fig, ax = mpl.subplots(figsize=(9, 6.5))
    labels = []
    for label, pts, k in chains:
        ok = [p for p in pts if p["success"]]
        line, = ax.plot([p["worst_alpha_deg"] for p in ok], [p["power_loss_W"] for p in ok], "o-", label=label)
        labels += [((p["worst_alpha_deg"], p["power_loss_W"]), p["label"], line.get_color(), 1.0) for p in ok
                   if p.get("label")]
        kp = next((p for p in ok if p["point"] == k), None)
        if kp:
            ax.plot(kp["worst_alpha_deg"], kp["power_loss_W"], "*", ms=18, color=line.get_color(),
                    markeredgecolor="k", label=f"knee of {label}")
    ax.set_xlabel("worst-case slip angle max |α| over the envelope [°]")
    ax.set_ylabel("mean power loss over the envelope [W]")
    ax.set_title("slip against power loss (ε-constraint Pareto front); each point labelled with its design")
    ax.grid(alpha=0.3)
    ax.margins(x=0.25, y=0.15)          # room for the labels of the end points
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    place_labels(fig, ax, labels, fontsize=7, offsets=LABEL_BESIDE, markers=[anchor for anchor, *_ in labels])
    save(fig, path, dpi=110)


def residual_map_figure(maps: list[tuple], regions: list[dict], path: Path, unit="deg"):
    """Residual maps over commanded γ [deg] × lateral load τ⊥ [N·m], one panel per (title, γ, τ⊥, values):
    each operating point a square coloured by its residual (mean over replicates), wherever the protocol put
    it (a grid, random points); the gap's regions boxed on the first panel by the γ and τ⊥ of their points."""
    mpl = _mpl()
    fig, axes = mpl.subplots(1, len(maps), figsize=(6 * len(maps), 4.6), squeeze=False)
    lim = max(float(np.nanmax(np.abs(v))) if np.isfinite(v).any() else 0.0 for *_, v in maps) or 1.0
    for ax, (title, g, t, v) in zip(axes[0], maps):
        ok = np.isfinite(v)
        sc = ax.scatter(g[ok], t[ok], c=v[ok], cmap="RdBu_r", vmin=-lim, vmax=lim, marker="s",
                        s=max(8.0, 6000.0 / max(ok.sum(), 1)), edgecolors="none")
        ax.scatter(g[~ok], t[~ok], marker="x", c="k", s=12, lw=0.8)      # no prediction (the model fails)
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("commanded γ [deg]")
        ax.set_ylabel("τ⊥ [N·m]")
        fig.colorbar(sc, ax=ax, label=f"measured − model [{unit}]")
    g0, t0 = maps[0][1], maps[0][2]
    dg, dl = 0.02 * (np.ptp(g0) or 1.0), 0.03 * (np.ptp(t0) or 0.1)
    for k, r in enumerate(regions):
        (ga, gb), (la, lb) = r["gamma_deg"], r["load_Nm"]
        axes[0][0].add_patch(mpl.Rectangle((ga - dg, la - dl), gb - ga + 2 * dg, lb - la + 2 * dl, fill=False,
                                           ec="k", lw=1.5, ls="--"))
        axes[0][0].annotate(f"R{k + 1}: {r['mean_residual_deg']:+.2f}°", (ga - dg, lb + dl), fontsize=8)
    fig.tight_layout()
    save(fig, path, dpi=100)


def diagnosis_fit_figure(curves: dict, path: Path):
    """Slip angle and efficiency against commanded γ at a few loads: the data (points), the base model and
    the diagnosed model (lines, held-out predictions). curves: {'loads': [...], 'panels': [(title, ylabel,
    [(load, γ, data, base, final)])]}."""
    mpl = _mpl()
    panels = curves["panels"]
    fig, axes = mpl.subplots(1, len(panels), figsize=(7 * len(panels), 4.8), squeeze=False)
    cmap = mpl.get_cmap("coolwarm")
    for ax, (title, ylabel, series) in zip(axes[0], panels):
        lo, hi = min(s[0] for s in series), max(s[0] for s in series)
        for load, g, d, b, f in series:
            c = cmap((load - lo) / max(hi - lo, 1e-12))
            ax.plot(g, d, "o", ms=4, color=c, label=f"data τ⊥ ≈ {load:+.2f} N·m")
            ax.plot(g, b, ":", color=c)
            ax.plot(g, f, "-", color=c)
        ax.set_title(f"{title} (dotted: base model, solid: diagnosed model)", fontsize=10)
        ax.set_xlabel("commanded γ [deg]")
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    save(fig, path, dpi=100)


def resteer_figure(ratios, load, table: dict, path: Path):
    """Brokowski Fig. 17: speed-ratio error by eq 23 [%] against the requested ratio, one line per method."""
    mpl = _mpl()
    fig, ax = mpl.subplots(figsize=(8, 5))
    for m, row in table.items():
        ax.plot(ratios, row["error_pct"], "o-", label=f"{m} (mean |error| {row['mean_abs_error_pct']:.1f} %)")
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xscale("log")
    ax.set_xticks(ratios)
    ax.set_xticklabels([f"{q:g}" for q in ratios])
    ax.set_xticks([], minor=True)       # the log scale's own minor labels ('6×10⁻¹') among the ratios asked for
    ax.set_xlabel("requested speed ratio ω2/ω1")
    ax.set_ylabel("error (requested − achieved)/requested [%]")
    ax.set_title(f"resteering under τ⊥ = {load:+.2f} N·m (Brokowski Fig. 17)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save(fig, path, dpi=110)


LIMIT_MARKERS = {"gross_slip": ("o", "gross slip"), "lost_contact": ("s", "lost contact"),
                 "pressure": ("^", "over the allowable pressure")}   # capacity_figure: a limit's marker


def _capacity_runs(gammas, contacts) -> list[tuple[float, str]]:
    """(γ at the middle of the run, text) for each run of neighbouring γ limited by the same contacts."""
    runs, start = [], 0
    for k in range(1, len(gammas) + 1):
        if k == len(gammas) or contacts[k] != contacts[start]:
            if contacts[start]:
                runs.append((0.5 * (gammas[start] + gammas[k - 1]), contacts[start]))
            start = k
    return runs


def capacity_figure(records: list[dict], path: Path):
    """Load capacity τ⊥ max and min [N·m] against γ [°] (the `capacity --json` records), one colour per
    variant, its envelope drawn in as a band, each point marked by its limit, the limiting contacts named
    once per run of γ they limit; where the model stopped (no capacity) a + at the load it held to."""
    mpl = _mpl()
    fig, ax = mpl.subplots(figsize=(11.5, 6.5))
    colours = variant_colours([r["name"] for r in records])
    labels, marks = [], []
    for r in records:
        c, env = colours[r["name"]], r["envelope"]
        ax.fill_between(env["gamma_deg"], *env["tau_perp_Nm"], color=c, alpha=0.12, lw=0)
        g = np.array([row["gamma_deg"] for row in r["capacity"]])
        for side in ("max", "min"):
            tau = np.array([np.nan if row[f"tau_perp_{side}_Nm"] is None else row[f"tau_perp_{side}_Nm"]
                            for row in r["capacity"]], float)
            ax.plot(g, tau, "-", color=c, lw=1.2, label=f"{r['name']}" if side == "max" else None)
            for limit, (marker, _) in LIMIT_MARKERS.items():
                on = np.array([row[f"limit_{side}"] == limit for row in r["capacity"]]) & np.isfinite(tau)
                ax.plot(g[on], tau[on], marker, color=c, ms=6, ls="none", mfc="white" if limit != "gross_slip" else c)
            held = np.array([np.nan if row[f"held_{side}_Nm"] is None else row[f"held_{side}_Nm"]
                             for row in r["capacity"]], float)
            ax.plot(g, held, "+", color=c, ms=10, mew=2, ls="none")
            names = [", ".join(row[f"contacts_{side}"]) for row in r["capacity"]]
            marks += [(x, y) for x, y in zip(g, tau) if np.isfinite(y)]
            labels += [((x, np.interp(x, g[np.isfinite(tau)], tau[np.isfinite(tau)])), text, c, 1.0)
                       for x, text in _capacity_runs(g, [n if np.isfinite(t) else "" for n, t in zip(names, tau)])]
    for limit, (marker, text) in LIMIT_MARKERS.items():
        ax.plot([], [], marker, color="k", mfc="white" if limit != "gross_slip" else "k", ls="none", label=text)
    ax.plot([], [], "+", color="k", ms=10, mew=2, ls="none", label="the model stops here\n(no steady state; no capacity)")
    ax.fill_between([], [], [], color="grey", alpha=0.2, label="operating envelope")
    ax.axhline(0, color="k", lw=0.5)
    safety = {r["safety"] for r in records}
    ax.set_title("load capacity: the largest τ⊥ before the first contact reaches a limit"
                 + (f" (gross slip at F/(μN) = 1/{safety.pop():g})" if safety != {1.0} and len(safety) == 1 else ""))
    ax.set_xlabel("commanded γ [°]")
    ax.set_ylabel("lateral load τ⊥ [N·m]")
    ax.grid(alpha=0.3)
    ax.margins(y=0.12)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    place_labels(fig, ax, labels, fontsize=8, offsets=LABEL_BESIDE, markers=marks)
    save(fig, path, dpi=110)


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
    mpl = _mpl()
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


CONTACT_CURVES = (("curve_longitudinal", "longitudinal creepage ξ [-]", "Fx/(μN) [-]", "longitudinal force"),
                  ("curve_lateral", "lateral creepage η [-]", "Fy/(μN) [-]", "lateral force"),
                  ("curve_spin", "spin creepage φ [1/m]", "Fy/(μN) [-]", "lateral force from spin"),
                  ("curve_spin_moment", "spin creepage φ [1/m]", "Mz/(μNℓ) [-]", "spin moment"))
ROLLER_STYLES = (("tab:blue", "-", "o"), ("tab:orange", "--", "s"), ("tab:green", "-.", "^"), ("tab:red", ":", "D"),
                 ("tab:purple", (0, (5, 1, 1, 1)), "v"), ("tab:brown", (0, (1, 2)), "P"))


def same_contacts(records: dict) -> list[list[str]]:
    """The rollers grouped by contact: rollers whose four curves agree to 1e-9 share a group (Kim's two
    drive rollers are one contact drawn twice), in the order of `records`."""
    groups: list[list[str]] = []
    for name, r in records.items():
        for g in groups:
            other = records[g[0]]
            if all(np.allclose(r[k], other[k], rtol=1e-9, atol=1e-12) for k, _, _, _ in CONTACT_CURVES):
                g.append(name)
                break
        else:
            groups.append([name])
    return groups


def group_label(group: list[str], records: dict) -> str:
    """'A, A_, B, B_ (drive, follower)': the rollers of a contact group and their roles."""
    roles = dict.fromkeys(records[n]["role"] for n in group)
    return f"{', '.join(group)} ({', '.join(roles)})"


def contact_figures(name: str, records: dict, folder: Path, stem: str) -> list[Path]:
    """`cvtdesign contact`'s figures, `<stem>_contact_curves.png` and `<stem>_contact_patches.png` in `folder`
    (stem: the variant file's): the creep–force curves (one panel per creepage, the linear theory's slope
    dotted; rollers with the same contact drawn once and named together, the others each in a colour, line
    style and marker of their own), the pure-spin moment against the pivoting moment μNℓ, and the contact
    patches drawn to scale [mm]. Returns the files written."""
    mpl = _mpl()
    fig, axes = mpl.subplots(1, 4, figsize=(19, 4.6), layout="constrained")
    groups = same_contacts(records)
    for (key, xlabel, ylabel, what), ax in zip(CONTACT_CURVES, axes):
        for k, g in enumerate(groups):
            r = records[g[0]]
            colour, ls, marker = ROLLER_STYLES[k % len(ROLLER_STYLES)]
            s, f = np.array(r[key]).T
            ax.plot(s, f, ls=ls, color=colour, lw=1.6, marker=marker, ms=4, markevery=(3 * k, 12),
                    label=group_label(g, records))
            ax.plot(s[:8], s[:8] * (f[1] / s[1]), ":", color=colour, lw=0.8)
        ax.axhline(1.0, color="k", lw=0.8)
        limit = "μNℓ (pivoting)" if key == "curve_spin_moment" else "μN (full slip)"
        ax.text(0.98, 1.01, limit, transform=ax.get_yaxis_transform(), fontsize=8, va="bottom", ha="right")
        ax.set(xlabel=xlabel, ylabel=ylabel, ylim=(0, 1.12), title=what)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, loc="lower right")
    fig.suptitle(f"{name}: creep–force curves and the spin moment at the preload (FASTSIM, Hertz traction bound; "
                 "dotted: linear theory)\nrollers with the same contact are drawn once, named together; curves on top "
                 "of each other are contacts that behave alike")
    curves_png = folder / f"{stem}_contact_curves.png"
    save(fig, curves_png, dpi=90)
    return [curves_png, _patch_figure(name, records, folder / f"{stem}_contact_patches.png", mpl)]


def _patch_figure(name: str, records: dict, path: Path, mpl) -> Path:
    """Each contact's Hertz ellipse to scale [mm] (rollers with the same contact in one panel), its
    semi-axes drawn: a along the rolling direction, b across it (the patch is 2a × 2b)."""
    groups = same_contacts(records)
    n = len(groups)
    fig, axes = mpl.subplots(1, n, figsize=(max(3.2 * n + 0.6, 8.0), 4.4), squeeze=False, layout="constrained")
    half = 1.2 * max(max(r["a_mm"], r["b_mm"]) for r in records.values())
    t = np.linspace(0, 2 * np.pi, 200)
    for ax, g in zip(axes[0], groups):
        r = records[g[0]]
        a, b = r["a_mm"], r["b_mm"]
        ax.fill(a * np.cos(t), b * np.sin(t), alpha=0.4)
        for end, label, align in (((a, 0), "a", {"ha": "center", "va": "bottom"}),
                                  ((0, b), "b", {"ha": "left", "va": "center"})):
            ax.annotate("", xy=end, xytext=(0, 0), arrowprops={"arrowstyle": "->", "color": "k", "lw": 1})
            ax.annotate(label, (end[0] / 2, end[1] / 2), xytext=(2, 2), textcoords="offset points", fontsize=9, **align)
        ax.set(xlim=(-half, half), ylim=(-half, half), aspect="equal", xlabel="rolling direction [mm]",
               title=f"{group_label(g, records)}\nsemi-axes a × b = {a:.2f} × {b:.2f} mm\npeak pressure p0 = "
                     f"{r['p0_MPa']:.2f} MPa")
        ax.title.set_fontsize(9)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("across [mm]")
    fig.suptitle(f"{name}: Hertz contact patches at the preload, to scale\n(the patch is 2a × 2b)")
    save(fig, path, dpi=90)
    return path


def tolerance_figure(title: str, label: str, sampled, first_order, nominal: float, effects: list[tuple[str, float]],
                     path: Path, top: int = 15):
    """A tolerance study's figure for one figure of merit (`label`, with its unit): left, the sampled values'
    histogram, the first-order prediction's (the linearised envelope's draws) outlined over it and the
    nominal marked; right, the dimensions ranked by their first-order effect (each alone, in the figure's
    unit; None: none), the `top` largest. Returns `path`."""
    mpl = _mpl()
    fig, (ax, bx) = mpl.subplots(1, 2, figsize=(13, 5.2), gridspec_kw={"width_ratios": [1, 1.2]})
    sampled, first_order = np.asarray(sampled, float), np.asarray(first_order, float)
    both = np.concatenate([sampled[np.isfinite(sampled)], first_order[np.isfinite(first_order)], [nominal]])
    bins = np.linspace(both.min(), both.max(), 31) if np.ptp(both) > 0 else 10
    ax.hist(sampled[np.isfinite(sampled)], bins=bins, density=True, color="tab:blue", alpha=0.55,
            label=f"sampled ({np.isfinite(sampled).sum()} samples)")
    ax.hist(first_order[np.isfinite(first_order)], bins=bins, density=True, histtype="step", color="k", lw=1.6,
            label="first order (linearised envelope, exact derivatives)")
    ax.axvline(nominal, color="tab:red", ls="--", label=f"nominal {nominal:.4g}")
    ax.set_xlabel(label)
    ax.set_ylabel("probability density")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    shown = effects[:top][::-1]
    bx.barh(range(len(shown)), [0.0 if e is None else e for _, e in shown], color="tab:orange")
    bx.set_yticks(range(len(shown)), [n for n, _ in shown], fontsize=8)
    bx.set_xlabel(f"effect of each tolerance alone (first order, spread of {label})")
    bx.set_title(f"which tolerance matters most ({min(top, len(effects))} of {len(effects)})", fontsize=10)
    bx.grid(alpha=0.3, axis="x")
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    save(fig, path, dpi=100)
    return path
