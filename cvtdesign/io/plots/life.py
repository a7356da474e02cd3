"""life's figures: each roller's temperature over the duty cycle, and each contact's life with its interval."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from cvtdesign.io.plots.base import figure_parts, save
from cvtdesign.io.plots.compare import variant_colours

LIMIT_HATCH = {"wear": "", "temperature": "//", "fatigue": "..", "runaway": "xx"}


def temperature_figure(curves: list[dict], path: Path):
    """Each roller's temperature [°C], one row per variant: on the left its cycle-mean from a cold start
    [min], on the right over one cycle [s] of the periodic state (the lumped model; the flash temperature is
    in the table's peak only). The materials' maximum in continuous use is drawn where it is in range, else
    named in the title. `curves`: per variant {name, rollers: {name: ((t, T_C), (t_warm, T_warm_C))},
    max_C: {name: T}}."""
    mpl = figure_parts()
    fig, axes = mpl.subplots(len(curves), 2, figsize=(12, 3.2 * len(curves) + 0.6), squeeze=False,
                             gridspec_kw={"width_ratios": [1, 1.4]})
    for (warm_ax, ax), v in zip(axes, curves):
        top = max(max(np.max(c[0][1]), np.max(c[1][1])) for c in v["rollers"].values())
        for name, ((t, T), (tw, Tw)) in v["rollers"].items():
            line, = ax.plot(t, T, lw=1.3, label=name)
            warm_ax.plot(tw / 60.0, Tw, lw=1.3, color=line.get_color())
        limits = sorted(set(v["max_C"].values()))
        shown = [m for m in limits if m <= top + 0.5 * (top - 25.0) + 5]
        for a in (warm_ax, ax):
            for m in shown:
                a.axhline(m, color="r", ls="--", lw=0.8)
            a.grid(alpha=0.3)
            a.set_ylabel("temperature [°C]")
        off = "" if shown else f" (max. in continuous use {', '.join(f'{m:.0f}' for m in limits)} °C, off scale)"
        warm_ax.set_title(f"{v['name']}: warming up from cold", fontsize=10)
        warm_ax.set_xlabel("time from a cold start [min]")
        ax.set_title(f"{v['name']}: over one cycle, once warm{off}", fontsize=10)
        ax.set_xlabel("time in the cycle [s]")
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    save(fig, path, dpi=100)


def life_figure(records: list[dict], intervals: list[dict], path: Path):
    """Each contact's life [h] as a bar, its 95 % interval as an error bar, on a log scale, the bar's hatch
    its limit; one colour per variant, the machine's life (its first contact's) as a line."""
    mpl = figure_parts()
    fig, ax = mpl.subplots(figsize=(max(7.0, 0.55 * sum(len(r["contacts"]) for r in records) + 3), 5.2))
    colours = variant_colours([r["name"] for r in records])
    x, ticks, labels = 0, [], []
    for r, iv in zip(records, intervals):
        c, start = colours[r["name"]], x
        for k in r["contacts"]:
            life = k["life_h"] if k["life_h"] else np.nan
            lo, hi = iv[k["contact"]]
            err = [[max(life - lo, 0)], [max(hi - life, 0)]] if np.isfinite(life) else None
            ax.bar(x, life, color=c, alpha=0.75, hatch=LIMIT_HATCH[k["limit"]], edgecolor="k", lw=0.5)
            if err is not None:
                ax.errorbar(x, life, yerr=err, color="k", capsize=3, lw=1)
            ticks.append(x)
            labels.append(f"{r['name']}\n{k['contact']}" if x == start else k["contact"])
            x += 1
        if r["life_h"]:
            ax.hlines(r["life_h"], start - 0.4, x - 0.6, color=c, ls="--", lw=1.2,
                      label=f"{r['name']}: {r['life_h']:.3g} h ({r['limit']} at {r['contact']})")
        x += 1
    for limit, hatch in LIMIT_HATCH.items():
        ax.fill_between([], [], [], facecolor="white", edgecolor="k", hatch=hatch, label=f"limit: {limit}")
    ax.set_xticks(ticks, labels, fontsize=7)
    ax.set_yscale("log")
    ax.set_ylabel("life [h] (95 % interval from the materials' uncertainty)")
    ax.set_title("life of each contact over the duty cycle")
    ax.grid(alpha=0.3, axis="y", which="both")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    save(fig, path, dpi=100)
