"""Design studies' figures: the slip/loss Pareto front and a tolerance study's distribution and ranking."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from cvtdesign.io.plots.base import figure_parts, place_labels, points_along, save

# centred over or under its point, where a label is plainly that point's (on the flat end of a front the points
# sit closer than a label is wide: they alternate), then the front's outside (up, right), then the other spots
FRONT_BESIDE = [spot for r in (1.6, 3, 5) for spot in ((0, 7 * r, "center", "bottom"), (0, -7 * r, "center", "top"),
                                                       (6 * r, 7 * r, "left", "bottom"), (6 * r, 0, "left", "center"),
                                                       (-6 * r, 7 * r, "right", "bottom"),
                                                       (6 * r, -7 * r, "left", "top"), (-6 * r, 0, "right", "center"),
                                                       (-6 * r, -7 * r, "right", "top"))]


def pareto_figure(chains: list[tuple[str, list[dict], int]], path: Path):
    """Slip/efficiency Pareto fronts (worst |α| [deg] against mean power loss [W]), knee marked, every point
    labelled with its design (its 'label', e.g. 'preload = 121.9 N, d = 48.8 mm'), the labels placed apart.
    chains: (label, points with worst_alpha_deg, power_loss_W, label, success, point), index of the knee
    point)."""
    mpl = figure_parts()
    fig, ax = mpl.subplots(figsize=(9, 6.5))
    labels, fronts = [], []
    for label, pts, k in chains:
        ok = [p for p in pts if p["success"]]
        line, = ax.plot([p["worst_alpha_deg"] for p in ok], [p["power_loss_W"] for p in ok], "o-", label=label)
        fronts.append(np.array([[p["worst_alpha_deg"], p["power_loss_W"]] for p in ok], float).reshape(-1, 2))
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
    place_labels(fig, ax, labels, fontsize=7, offsets=FRONT_BESIDE, markers=points_along(*fronts, per_segment=12),
                 gap=4)
    save(fig, path, dpi=110)




def tolerance_figure(title: str, label: str, sampled, first_order, nominal: float, effects: list[tuple[str, float]],
                     path: Path, top: int):
    """A tolerance study's figure for one figure of merit (`label`, with its unit): left, the sampled values'
    histogram, the first-order prediction's (the linearised envelope's draws) outlined over it and the
    nominal marked; right, the dimensions ranked by their first-order effect (each alone, in the figure's
    unit; None: none), the `top` largest (as many as the printed ranking: cli.tolerance.RANKED). Returns `path`."""
    mpl = figure_parts()
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
