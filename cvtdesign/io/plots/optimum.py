"""The figures of optimise's report: how the solve converged, and how much room each constraint family
leaves at the optimum. (The optimum beside its base design is io.plots.layout.beside_figure.)"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from cvtdesign.io.plots.base import figure_parts, save


def convergence_figure(history: list[dict], start_objectives: list, objective_label: str, path: Path):
    """Left: the best start's IPOPT iterations, the objective (`objective_label`, with its unit) and the
    primal infeasibility (log scale), each working-set round shaded in turn (a round adds the rows the last
    one violated, so the objective may rise between rounds). Right: each start's final objective (failed
    starts marked at the foot), the best marked. history: [{round, objective, infeasibility}]."""
    mpl = figure_parts()
    fig, (ax, ax_starts) = mpl.subplots(1, 2, figsize=(12, 4.4), layout="constrained",
                                        gridspec_kw={"width_ratios": (2, 1)})
    k = np.arange(len(history))
    obj = [h["objective"] for h in history]
    ax.plot(k, obj, "o-", ms=3, color="tab:blue", label=objective_label)
    rounds = [h["round"] for h in history]
    for r in sorted(set(rounds))[1::2]:
        at = [i for i, q in enumerate(rounds) if q == r]
        ax.axvspan(at[0] - 0.5, at[-1] + 0.5, color="grey", alpha=0.12, lw=0)
    ax.set(xlabel="IPOPT iteration (working-set rounds shaded in turn)", ylabel=objective_label,
           title=f"the best start's iterations ({len(set(rounds))} working-set round"
                 f"{'s' if len(set(rounds)) != 1 else ''})")
    inf = ax.twinx()
    inf.semilogy(k, np.maximum([h["infeasibility"] for h in history], 1e-16), ".:", color="tab:red", ms=3)
    inf.set_ylabel("primal infeasibility (constraint violation) [-]", color="tab:red")
    ax.grid(alpha=0.3)
    ok = [(i, o) for i, o in enumerate(start_objectives) if o is not None]
    failed = [i for i, o in enumerate(start_objectives) if o is None]
    if ok:
        ax_starts.plot(*zip(*ok), "o", color="tab:blue", label="start's optimum")
        best = min(ok, key=lambda x: x[1])
        ax_starts.plot(*best, "*", ms=16, color="gold", markeredgecolor="k", label="best (reported)")
    if failed:
        foot = min(o for _, o in ok) if ok else 0.0
        ax_starts.plot(failed, [foot] * len(failed), "x", color="tab:red", label="failed start")
    ax_starts.set(xlabel="start (0: the base design)", ylabel=objective_label, title="every start of the multistart")
    ax_starts.ticklabel_format(axis="y", useOffset=False)
    ax_starts.set_xticks(range(0, len(start_objectives), max(1, len(start_objectives) // 10)))
    if ok and np.ptp([o for _, o in ok]) < 1e-6 * max(abs(o) for _, o in ok):     # every start found the same
        mid = ok[0][1]
        ax_starts.set_ylim(mid - 0.05 * abs(mid) - 1e-9, mid + 0.05 * abs(mid) + 1e-9)
    ax_starts.legend(fontsize=8)
    ax_starts.grid(alpha=0.3)
    save(fig, path, dpi=90)


def slack_figure(rows: list[tuple[str, str, float, bool]], path: Path):
    """Each constraint family's most binding row: a bar of its slack as a share of its bound [%] (0: the
    optimum sits on it), labelled with the slack in its unit. A bar past 100 % is cut there and drawn so:
    hatched, an arrow at its end, its label saying so beside the share ('bar cut at 100 %: 40 mm (1900 % of
    the bound)'), so that it is never read as a full 100 % bar. rows: (family, label, share [%], active)."""
    mpl = figure_parts()
    fig, ax = mpl.subplots(figsize=(9, 0.45 * len(rows) + 1.6), layout="constrained")
    y = np.arange(len(rows))[::-1]
    past = [share > 100.0 for _, _, share, _ in rows]
    colours = ["tab:red" if active else "tab:blue" for *_, active in rows]
    bars = ax.barh(y, [min(share, 100.0) for _, _, share, _ in rows], color=colours, height=0.6)
    for bar, yi, cut, (_, text, share, active) in zip(bars, y, past, rows):
        label = "active: the optimum sits on it" if active else text
        if cut:
            bar.set(hatch="///", facecolor="white", edgecolor=bar.get_facecolor())
            ax.plot(100.0, yi, marker=">", ms=9, color=bar.get_edgecolor(), clip_on=False)
            label = f"bar cut at 100 %: {label}"
        ax.text(min(share, 100.0) + 3.5, yi, label, va="center", fontsize=8)
    ax.set_yticks(y, [name for name, *_ in rows])
    ax.set(xlim=(0, 160), xlabel="slack at the optimum, as a share of the bound [%]",
           title="room left by each constraint family (its most binding row)")
    ax.set_xticks([0, 25, 50, 75, 100])
    ax.grid(alpha=0.3, axis="x")
    save(fig, path, dpi=90)
