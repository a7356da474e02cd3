"""The diagnosis' figures: where the gap lies (residual maps), the fitted curves and the resteering commands."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from cvtdesign.io.plots.base import figure_parts, save


def residual_map_figure(maps: list[tuple], regions: list[dict], path: Path, unit="deg"):
    """Residual maps over commanded γ [deg] × lateral load τ⊥ [N·m], one panel per (title, γ, τ⊥, values):
    each operating point a square coloured by its residual (mean over replicates), wherever the protocol put
    it (a grid, random points), each panel on its own symmetric scale (on the first's, a diagnosed model's
    residuals were a flat grey); the gap's regions boxed on the first panel by the γ and τ⊥ of their points,
    each labelled inside its box (a label above a box at the top load was cut by the panel's edge)."""
    mpl = figure_parts()
    fig, axes = mpl.subplots(1, len(maps), figsize=(6 * len(maps), 4.6), squeeze=False)
    for ax, (title, g, t, v) in zip(axes[0], maps):
        ok = np.isfinite(v)
        lim = float(np.nanmax(np.abs(v))) if ok.any() else 0.0
        lim = lim or 1.0
        sc = ax.scatter(g[ok], t[ok], c=v[ok], cmap="RdBu_r", vmin=-lim, vmax=lim, marker="s",
                        s=max(8.0, 6000.0 / max(ok.sum(), 1)), edgecolors="none")
        ax.scatter(g[~ok], t[~ok], marker="x", c="k", s=12, lw=0.8)      # no prediction (the model fails)
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("commanded γ [deg]")
        ax.set_ylabel("τ⊥ [N·m]")
        fig.colorbar(sc, ax=ax, label=f"measured − model [{unit}]")
    g0, t0 = maps[0][1], maps[0][2]
    dg, dl = 0.02 * (np.ptp(g0) or 1.0), 0.03 * (np.ptp(t0) or 0.1)
    corners: dict = {}           # labels at one corner (regions nested at a corner) stacked down, not overlaid
    for k, r in enumerate(regions):
        (ga, gb), (la, lb) = r["gamma_deg"], r["load_Nm"]
        axes[0][0].add_patch(mpl.Rectangle((ga - dg, la - dl), gb - ga + 2 * dg, lb - la + 2 * dl, fill=False,
                                           ec="k", lw=1.5, ls="--"))
        corner = (round(ga / (4 * dg)), round(lb / (4 * dl)))
        below = corners[corner] = corners.get(corner, -1) + 1
        axes[0][0].annotate(f"R{k + 1}: {r['mean_residual_deg']:+.2f}°", (ga - dg, lb + dl), xytext=(3, -3 - 11 * below),
                            textcoords="offset points", va="top", fontsize=8,
                            bbox=dict(boxstyle="square,pad=0.15", fc="white", ec="none", alpha=0.85))
    fig.tight_layout()
    save(fig, path, dpi=100)


def diagnosis_fit_figure(curves: dict, path: Path):
    """Slip angle and efficiency against commanded γ at a few loads: the data (points), the base model and
    the diagnosed model (lines, held-out predictions). curves: {'loads': [...], 'panels': [(title, ylabel,
    [(load, γ, data, base, final)])]}."""
    mpl = figure_parts()
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


# each method its own marker and line, drawn in this order, so that one that coincides with another stays seen
# (the nominal line was hidden under the fitted one): larger open markers under smaller filled ones
METHOD_STYLE = {"ideal": dict(marker="o", ls="-", ms=7, color="0.35"),
                "nominal": dict(marker="s", ls="-", ms=10, mfc="none", mew=1.6, lw=2.4, color="tab:blue"),
                "fitted": dict(marker="^", ls="--", ms=6, color="tab:orange"),
                "lookup": dict(marker="D", ls=":", ms=5, color="tab:green")}


def resteer_figure(ratios, load, table: dict | None, path: Path, commands: dict | None = None):
    """Brokowski Fig. 17: speed-ratio error by eq 23 [%] against the requested ratio, one line per method
    (`table`: each method's scores on the rig, resteer.achieved). Without a rig to score them (table None),
    each method's commanded γ less the ideal command [°] (`commands`: resteer.commands), what the model
    corrects."""
    mpl = figure_parts()
    fig, ax = mpl.subplots(figsize=(8, 5))
    if table is not None:
        for m, row in table.items():
            ax.plot(ratios, row["error_pct"], **METHOD_STYLE.get(m, {}),
                    label=f"{m} (mean |error| {row['mean_abs_error_pct']:.1f} %)")
        ax.set_ylabel("error (requested − achieved)/requested [%]")
        ax.set_title(f"resteering under τ⊥ = {load:+.2f} N·m (Brokowski Fig. 17)")
    else:
        ideal = np.degrees(np.asarray(commands["methods"]["ideal"], float))
        for m, gs in commands["methods"].items():
            ax.plot(ratios, np.degrees(np.asarray(gs, float)) - ideal, **METHOD_STYLE.get(m, {}), label=m)
        ax.set_ylabel("commanded γ − ideal command [°]")
        ax.set_title(f"steering commands under τ⊥ = {load:+.2f} N·m: the correction of the ideal command")
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xscale("log")
    ax.set_xticks(ratios)
    ax.set_xticklabels([f"{q:g}" for q in ratios])
    ax.set_xticks([], minor=True)       # the log scale's own minor labels ('6×10⁻¹') among the ratios asked for
    ax.set_xlabel("requested speed ratio ω2/ω1")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save(fig, path, dpi=110)
