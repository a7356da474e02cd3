"""compare's figure: the slip angle, its parts and the efficiency against γ, per variant, with bands and flags."""
from __future__ import annotations

import zlib
from pathlib import Path

import numpy as np

from cvtdesign.core.status import Status
from cvtdesign.io.plots.base import figure_parts, save


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
# (the shipped variants and the shipped studies' optima hash to different colours: box red, box green,
# existing purple, unequal pink, box_box_placement orange, box_box_placement brown)
EXISTING_COLOUR, IDEAL_COLOUR = "#1f77b4", "#000000"
KIM_CVT = ("existing", "existing_kim")       # Kim's existing CVT, on the default basis and under his own law
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
        if name in KIM_CVT:
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
    ok = {name: np.abs(res["alpha"][res["status"] == Status.OK]) for name, res in results}
    worst = {name: float(np.nanmax(a)) if np.isfinite(a).any() else np.inf for name, a in ok.items()}
    keep = sorted(worst, key=lambda n: (n not in KIM_CVT, worst[n]))[:PANELS_MAX]
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
                if np.isfinite(band).any():        # the 95 % interval from every uncertain input
                    ax.fill_between(g, y - band, y + band, color=colour, alpha=0.18, lw=0)
                bad = status != Status.OK
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
    idle = (res["status"] == Status.OK) & ~np.isfinite(eff)
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
                                     label="shaded: 95 % interval from every uncertain input (first order)"))
    handles.append(mpl.Line2D([], [], color=IDEAL_COLOUR, lw=1.5, label="ideal CVT (α = 0, efficiency 1)"))
    for L, ls, marker in sorted(_loads(shown, loads), key=lambda x: x[0]):
        handles.append(mpl.Line2D([], [], color="dimgrey", ls=ls, marker=marker, ms=4, label=f"τ⊥ = {L:+g} N·m"))
    handles.append(mpl.Line2D([], [], color="dimgrey", marker="x", ls="none", label="left out (status ≠ ok), at "
                              "the panel's foot"))
    handles.append(mpl.Rectangle((0, 0), 1, 1, fc="lightgrey", ec="grey", hatch="///",
                                 label="no power delivered (τ⊥ = 0, or losses above what the load returns: "
                                       "efficiency undefined)"))
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
    mpl = figure_parts()
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
