"""transient's figures: the step response over time, the Bode plot of the small-signal response, and the ratio
while a constraint is rendered; one colour per variant. Each takes the `transient --json` records and each
variant's curves (uses.transient.curves)."""
from __future__ import annotations

import textwrap
from pathlib import Path

from cvtdesign.io.plots.base import figure_parts, save
from cvtdesign.io.plots.compare import variant_colours

POINT_STYLES = ("-", "--", ":", "-.")     # the Bode plot: one line style per operating point


def _note(ax, text: str):
    ax.text(0.5, 0.5, text, transform=ax.transAxes, ha="center", va="center", fontsize=9, color="0.4", wrap=True)


def _assumed(fig, rows: list[dict]):
    """A footer naming the parameters the figure rests on that are assumed, not the variants' own, wrapped to
    the figure's width; the figure laid out above it."""
    names = sorted({k for r in rows for k in r["parameters"]["assumed"]})
    width, height = fig.get_size_inches()
    lines = textwrap.wrap("assumed, not the variants' own (docs/dynamics.md): " + ", ".join(names),
                          int(width * 17)) if names else []
    fig.tight_layout(rect=(0, len(lines) * 10 / (72 * height) + 0.005, 1, 1))
    if lines:
        fig.text(0.01, 0.005, "\n".join(lines), fontsize=7, color="0.35", ha="left", va="bottom")


def step_figure(rows: list[dict], curves: list[dict], path: Path):
    """The step of the command: the axis angle γ_axis with the command γ_cmd [°], the speed ratio ω2/ω1 [-] and
    the slip angle α [°] against time [ms]; a variant without a response (no steady state) is named, not drawn."""
    mpl = figure_parts()
    fig, axes = mpl.subplots(3, 1, figsize=(9, 8.5), sharex=True)
    colours = variant_colours([r["name"] for r in rows])
    missing = []
    for r, c in zip(rows, curves):
        d, col = c["step"], colours[r["name"]]
        if d is None:
            missing.append(f"{r['name']}: {r['step']['reason']}")
            continue
        axes[0].plot(d["t_ms"], d["gamma_cmd_deg"], color=col, lw=0.9, ls="--")
        axes[0].plot(d["t_ms"], d["gamma_axis_deg"], color=col, lw=1.4, label=f"{r['name']}: γ_axis")
        axes[1].plot(d["t_ms"], d["ratio"], color=col, lw=1.4, label=r["name"])
        axes[2].plot(d["t_ms"], d["alpha_deg"], color=col, lw=1.4, label=r["name"])
        lag = r["step"]["lag_s"]
        if lag is not None:
            axes[0].axvline(lag * 1e3, color=col, lw=0.6, ls=":")
    s = rows[0]["step"]
    axes[0].set_title(f"step of γ_cmd {s['gamma_from_deg']:g}° → {s['gamma_to_deg']:g}° from τ⊥ {s['load_Nm']:g} N·m, "
                      "shaft 2's torque held (dashed: the command; dotted: the lag, 50 %)", fontsize=10)
    for ax, label in zip(axes, ("γ [°]", "speed ratio ω2/ω1 [-]", "slip angle α [°]")):
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time from the step [ms]")
    settled = [r["step"]["settle_s"] for r in rows if r["step"]["settle_s"] is not None]
    ends = [c["step"]["t_ms"][-1] for c in curves if c["step"] is not None]
    if settled and ends and len(settled) == len(ends):       # up to twice the slowest settling, where all settle
        axes[-1].set_xlim(-0.02 * min(ends), min(max(ends), 2e3 * max(settled)))
    if missing:
        _note(axes[1], "no response: " + "; ".join(missing))
    axes[0].legend(fontsize=8, loc="lower right")
    _assumed(fig, rows)
    save(fig, path, dpi=100)


def bode_figure(rows: list[dict], curves: list[dict], path: Path):
    """The small-signal response to the commanded γ at each operating point: |H|/|H(0)| [dB] and phase [°] of
    γ_axis/γ_cmd (left) and of the ratio ω2/ω1 (right) against frequency [Hz], −3 dB drawn in; colour the
    variant, line style the operating point."""
    mpl = figure_parts()
    fig, axes = mpl.subplots(2, 2, figsize=(12, 7.5), sharex=True)
    colours = variant_colours([r["name"] for r in rows])
    drawn = 0
    for r, c in zip(rows, curves):
        for k, b in enumerate(c["bode"]):
            style, col = POINT_STYLES[k % len(POINT_STYLES)], colours[r["name"]]
            label = f"{r['name']}, γ {b['gamma_deg']:g}°"
            for j, sig in enumerate(("gamma_axis", "ratio")):
                axes[0, j].semilogx(b["f_Hz"], b[f"{sig}_dB"], color=col, ls=style, lw=1.3, label=label)
                axes[1, j].semilogx(b["f_Hz"], b[f"{sig}_phase_deg"], color=col, ls=style, lw=1.3)
            drawn += 1
    load = rows[0]["bandwidth_Hz"][0]["load_Nm"] if rows[0]["bandwidth_Hz"] else None
    for j, what in enumerate(("γ_axis / γ_cmd", "speed ratio ω2/ω1 / γ_cmd")):
        axes[0, j].axhline(-3, color="0.3", lw=0.8, ls="--")
        axes[0, j].set_title(f"{what}" + (f" from τ⊥ {load:g} N·m, τ2 held" if load is not None else ""), fontsize=10)
        axes[0, j].set_ylabel("|H| / |H(0)| [dB]")
        axes[1, j].set_ylabel("phase [°]")
        axes[1, j].set_xlabel("frequency [Hz]")
        for ax in axes[:, j]:
            ax.grid(alpha=0.3, which="both")
            ax.xaxis.set_major_formatter(lambda x, pos: f"{x:g}")     # plain numbers, not mathtext's 10^k
            ax.xaxis.set_minor_formatter(lambda x, pos: "")
        axes[0, j].set_ylim(bottom=max(-60, axes[0, j].get_ylim()[0]))
    if drawn:
        axes[0, 0].legend(fontsize=7, loc="lower left")
    else:
        _note(axes[0, 0], "no stable steady state at any operating point")
    _assumed(fig, rows)
    save(fig, path, dpi=100)


def render_figure(rows: list[dict], curves: list[dict], path: Path):
    """Rendering a constraint, one panel per variant: the commanded ratio ω2/ω1, the dynamic model's and the
    quasi-static model's against time [s] (the errors are taken over the last period)."""
    mpl = figure_parts()
    fig, axes = mpl.subplots(len(rows), 1, figsize=(9, 3.2 * len(rows) + 0.6), squeeze=False)
    colours = variant_colours([r["name"] for r in rows])
    for ax, r, c in zip(axes[:, 0], rows, curves):
        d, rec = c["render"], r["rendering"]
        ax.set_title(f"{r['name']}: ratio profile at {rec['frequency_Hz']:g} Hz from τ⊥ {rec['load_Nm']:g} N·m, "
                     "shaft 2's torque held", fontsize=10)
        ax.set_ylabel("speed ratio ω2/ω1 [-]")
        ax.grid(alpha=0.3)
        if d is None:
            _note(ax, f"not rendered: {rec['reason']}")
            continue
        ax.plot(d["t_s"], d["commanded"], color="0.2", lw=1.0, ls="--", label="commanded")
        ax.plot(d["t_s"], d["quasi_static"], color="0.55", lw=1.2, label="quasi-static model")
        ax.plot(d["t_s"], d["dynamic"], color=colours[r["name"]], lw=1.4, label="dynamic model")
        period = 1.0 / d["frequency_Hz"]
        ax.axvspan(d["t_s"][-1] - period, d["t_s"][-1], color="0.9", zorder=0)
        ax.legend(fontsize=8, loc="upper left")
    axes[-1, 0].set_xlabel("time [s] (shaded: the period the errors are taken over)")
    _assumed(fig, rows)
    save(fig, path, dpi=100)
