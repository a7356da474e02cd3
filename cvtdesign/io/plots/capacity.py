"""capacity's figure: the largest τ⊥ at each γ, each point marked by its limit (the contacts', the usable ratio's,
the runaway's), the envelope drawn in."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from cvtdesign.io.plots.base import LABEL_BESIDE, figure_parts, place_labels, points_along, save
from cvtdesign.io.plots.compare import variant_colours


LIMIT_MARKERS = {"gross_slip": ("o", "gross slip"), "lost_contact": ("s", "lost contact"),
                 "pressure": ("^", "over the allowable pressure"), "usable_ratio": ("D", "usable ratio: |α| at its bound"),
                 "runaway": ("v", "runaway: ω2/ω1 → ∞")}   # capacity_figure: a limit's marker


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
    once per run of γ they limit; where the model stopped (no capacity) a + at the load it held to; a star on
    the axis where drive rollers pivot with no load (`pivoting`). Only what occurs is in the legend."""
    mpl = figure_parts()
    fig, ax = mpl.subplots(figsize=(11.5, 6.5))
    colours = variant_colours([r["name"] for r in records])
    labels, marks, seen = [], [], set()
    for r in records:
        c, env = colours[r["name"]], r["envelope"]
        ax.fill_between(env["gamma_deg"], *env["tau_perp_Nm"], color=c, alpha=0.12, lw=0)
        g = np.array([row["gamma_deg"] for row in r["capacity"]])
        for side in ("max", "min"):
            tau = np.array([np.nan if row[f"tau_perp_{side}_Nm"] is None else row[f"tau_perp_{side}_Nm"]
                            for row in r["capacity"]], float)
            ax.plot(g, tau, "-", color=c, lw=1.2, label=f"{r['name']}" if side == "max" else None)
            seen |= {"interval"} if _interval_band(ax, g, r["capacity"], side, c) else set()
            for limit, (marker, _) in LIMIT_MARKERS.items():
                on = np.array([row[f"limit_{side}"] == limit for row in r["capacity"]]) & np.isfinite(tau)
                seen |= {limit} if on.any() else set()
                ax.plot(g[on], tau[on], marker, color=c, ms=6, ls="none", mfc="white" if limit != "gross_slip" else c)
            held = np.array([np.nan if row[f"held_{side}_Nm"] is None else row[f"held_{side}_Nm"]
                             for row in r["capacity"]], float)
            ax.plot(g, held, "+", color=c, ms=10, mew=2, ls="none")
            seen |= {"stopped"} if np.isfinite(held).any() else set()
            marks += [(x, y) for x, y in zip(g, held) if np.isfinite(y)]
            names = [", ".join(row[f"contacts_{side}"]) for row in r["capacity"]]
            marks += [(x, y) for x, y in zip(g, tau) if np.isfinite(y)] + list(points_along(np.column_stack([g, tau])))
            labels += [((x, np.interp(x, g[np.isfinite(tau)], tau[np.isfinite(tau)])), text, c, 1.0)
                       for x, text in _capacity_runs(g, [n if np.isfinite(t) else "" for n, t in zip(names, tau)])]
        pivots = [p["gamma_deg"] for p in r["pivoting"]["points"]]
        ax.plot(pivots, np.zeros(len(pivots)), "*", color=c, ms=13, mec="k", mew=0.6, ls="none", zorder=5)
        seen |= {"pivoting"} if pivots else set()
        marks += [(x, 0.0) for x in pivots]
    for limit, (marker, text) in LIMIT_MARKERS.items():
        if limit in seen:
            ax.plot([], [], marker, color="k", mfc="white" if limit != "gross_slip" else "k", ls="none", label=text)
    if "pivoting" in seen:
        ax.plot([], [], "*", color="grey", ms=13, mec="k", mew=0.6, ls="none",
                label="drive rollers pivot and slide\nwith no load (a loss, no limit)")
    if "stopped" in seen:
        ax.plot([], [], "+", color="k", ms=10, mew=2, ls="none", label="the model stops here\n(no steady state; no capacity)")
    if "interval" in seen:
        ax.fill_between([], [], [], facecolor="none", edgecolor="grey", hatch="////", lw=0,
                        label="95 % interval of the capacity\n(every uncertain input)")
    for r in records:                               # the band's own colour, as drawn
        ax.fill_between([], [], [], color=colours[r["name"]], alpha=0.12,
                        label="operating envelope" + (f" ({r['name']})" if len(records) > 1 else ""))
    ax.axhline(0, color="k", lw=0.5)
    safety = {r["safety"] for r in records}
    bound = {float(b) if b is not None and np.isfinite(b) else None for b in (r["max_slip_deg"] for r in records)}
    slip = (f"|α| passes {next(iter(bound)):.4g}°, " if bound != {None} and len(bound) == 1
            else "|α| passes its bound, " if bound != {None} else "")
    ax.set_title(f"load capacity: the largest τ⊥ before {slip}the ratio runs away or a contact reaches a limit"
                 + (f" (gross slip at F/(μN) = 1/{safety.pop():g})" if safety != {1.0} and len(safety) == 1 else ""),
                 fontsize=10)
    ax.set_xlabel("commanded γ [°]")
    ax.set_ylabel("lateral load τ⊥ [N·m]")
    ax.grid(alpha=0.3)
    ax.margins(y=0.12)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    place_labels(fig, ax, labels, fontsize=8, offsets=LABEL_BESIDE, markers=marks)
    save(fig, path, dpi=110)


def _interval_band(ax, g, rows: list[dict], side: str, colour) -> bool:
    """Hatch each capacity's 95 % interval (`tau_perp_<side>_Nm_interval`) between its ends over γ; whether
    there was any."""
    ends = np.array([row.get(f"tau_perp_{side}_Nm_interval") or (np.nan, np.nan) for row in rows], float)
    if not np.isfinite(ends).any():
        return False
    ax.fill_between(g, ends[:, 0], ends[:, 1], facecolor="none", edgecolor=colour, hatch="////", lw=0, alpha=0.5)
    return True
