"""Matplotlib figures (Agg backend, written as PNG by output.write_file: atomically, umask's mode)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from cvtdesign.io.output import OutputError, write_file


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save(fig, path: Path, dpi=80):
    """Write a figure with output.write_file (matplotlib draws into the temporary file, which is then
    renamed onto `path`); the figure is closed either way."""
    path = Path(path)
    try:
        write_file(path, lambda tmp: fig.savefig(tmp, dpi=dpi, format=path.suffix[1:] or "png"), kind="plot")
    finally:
        _plt().close(fig)


def compare_figure(results: list[tuple[str, dict]], path: Path, loads=(-1.0, -0.5, 0.5, 1.0)):
    """One row per variant: α, its steering part and its drive part against commanded γ at several loads
    (Kim Figs 20-21), and the efficiency map over γ and τ⊥ with the points where the physics stops holding
    marked (lost contact, gross slip, not converged)."""
    plt = _plt()
    n = len(results)
    fig, axes = plt.subplots(n, 4, figsize=(17, 3.4 * n), squeeze=False)
    cmap = plt.get_cmap("coolwarm")
    for row, (name, res) in zip(axes, results):
        g = np.degrees(res["gamma_cmd"][:, 0])
        lg = res["load"][0]
        for ax, key, title in zip(row, ("alpha", "alpha_steering", "alpha_drive"),
                                  ("slip angle α", "steering part γ_axis − γ_cmd", "drive part")):
            for L in loads:
                j = int(np.argmin(np.abs(lg - L)))
                ax.plot(g, np.degrees(res[key][:, j]), "o-", ms=3,
                        color=cmap((lg[j] - lg.min()) / max(np.ptp(lg), 1e-12)), label=f"τ⊥ = {lg[j]:+.2g} N·m")
            ax.axhline(0, color="k", lw=0.5)
            ax.set_title(f"{name}: {title}", fontsize=10)
            ax.set_xlabel("commanded γ [deg]")
            ax.set_ylabel("[deg]")
            ax.grid(alpha=0.3)
        row[0].legend(fontsize=7)
        cs = row[3].contourf(np.degrees(res["gamma_cmd"]), res["load"], np.clip(res["efficiency"], 0, 1),
                             levels=np.linspace(0, 1, 11), cmap="viridis")
        fig.colorbar(cs, ax=row[3], label="efficiency")
        for code, marker, colour, label in ((1, "+", "grey", "not converged"), (2, "x", "k", "lost contact"),
                                            (3, "x", "r", "gross slip")):
            bad = res["status"] == code
            if bad.any():
                row[3].plot(np.degrees(res["gamma_cmd"][bad]), res["load"][bad], marker, color=colour, ms=4,
                            ls="none", label=label)
        if (res["status"] != 0).any():
            row[3].legend(fontsize=7, loc="upper right")
        row[3].set_title(f"{name}: efficiency (out/in)", fontsize=10)
        row[3].set_xlabel("commanded γ [deg]")
        row[3].set_ylabel("τ⊥ [N·m]")
    h = 3.4 * n
    fig.subplots_adjust(left=0.05, right=0.97, bottom=0.55 / h, top=1 - 0.3 / h, wspace=0.3, hspace=0.45)
    save(fig, path)


def worker(conn):
    """Plotting process: imports matplotlib at once (while the parent computes), then draws what it is
    sent, (figure function name, args), and answers None or an error text."""
    _plt()
    try:
        name, args = conn.recv()
    except EOFError:
        return
    try:
        globals()[name](*args)
        conn.send(None)
    except OutputError as e:  # raised again by the parent (Background.wait): one line, exit status 2
        conn.send(e)
    except Exception as e:  # reported by the parent as one line
        conn.send(f"{type(e).__name__}: {e}")


class Background:
    """Run figure functions of this module in a forked process that has matplotlib ready.

    Start it before the computation; `draw` hands over the data; `wait` returns the error text or None
    (a file that could not be written is raised as the OutputError it was)."""

    def __init__(self):
        import multiprocessing

        ctx = multiprocessing.get_context("fork")
        self.conn, child = ctx.Pipe()
        self.proc = ctx.Process(target=worker, args=(child,), daemon=True)
        self.proc.start()

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
        if self.proc.is_alive():
            self.proc.join(timeout=0.1)
            if self.proc.is_alive():
                self.proc.terminate()


def pareto_figure(chains: list[tuple[str, list[dict], int]], path: Path):
    """Slip/efficiency Pareto fronts (worst |α| [deg] against mean power loss [W]), knee marked, every point
    labelled with the stem of its variant file. chains: (label, points with worst_alpha_deg, power_loss_W,
    variant_file, success, point), index of the knee point)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(8, 5.5))
    for label, pts, k in chains:
        ok = [p for p in pts if p["success"]]
        x = [p["worst_alpha_deg"] for p in ok]
        y = [p["power_loss_W"] for p in ok]
        line, = ax.plot(x, y, "o-", label=label)
        for p in ok:
            if p.get("variant_file"):
                ax.annotate(Path(p["variant_file"]).stem, (p["worst_alpha_deg"], p["power_loss_W"]), fontsize=6,
                            xytext=(4, 3), textcoords="offset points", color=line.get_color())
        kp = next((p for p in ok if p["point"] == k), None)
        if kp:
            ax.plot(kp["worst_alpha_deg"], kp["power_loss_W"], "*", ms=18, color=line.get_color(),
                    markeredgecolor="k", label=f"knee of {label}")
    ax.set_xlabel("worst-case slip angle max |α| over the envelope [deg]")
    ax.set_ylabel("mean power loss over the envelope [W]")
    ax.set_title("slip against power loss (ε-constraint Pareto front)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save(fig, path, dpi=110)


def residual_map_figure(gamma_levels, load_levels, maps: list[tuple[str, np.ndarray]], regions: list[dict],
                        path: Path, unit="deg"):
    """Residual maps over commanded γ [deg] × lateral load τ⊥ [N·m] (mean over replicates per operating point),
    one panel per (title, grid); the gap's regions outlined on the first panel."""
    plt = _plt()
    fig, axes = plt.subplots(1, len(maps), figsize=(6 * len(maps), 4.6), squeeze=False)
    lim = max(float(np.nanmax(np.abs(m))) for _, m in maps) or 1.0
    for ax, (title, grid) in zip(axes[0], maps):
        pc = ax.pcolormesh(gamma_levels, load_levels, grid.T, cmap="RdBu_r", vmin=-lim, vmax=lim, shading="nearest")
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("commanded γ [deg]")
        ax.set_ylabel("τ⊥ [N·m]")
        fig.colorbar(pc, ax=ax, label=f"measured − model [{unit}]")
    dg = np.min(np.diff(gamma_levels)) / 2 if len(gamma_levels) > 1 else 1
    dl = np.min(np.diff(load_levels)) / 2 if len(load_levels) > 1 else 0.05
    for k, r in enumerate(regions):
        (g0, g1), (l0, l1) = r["gamma_deg"], r["load_Nm"]
        axes[0][0].add_patch(plt.Rectangle((g0 - dg, l0 - dl), g1 - g0 + 2 * dg, l1 - l0 + 2 * dl, fill=False,
                                           ec="k", lw=1.5, ls="--"))
        axes[0][0].annotate(f"R{k + 1}: {r['mean_residual_deg']:+.2f}°", (g0 - dg, l1 + dl), fontsize=8)
    fig.tight_layout()
    save(fig, path, dpi=100)


def diagnosis_fit_figure(curves: dict, path: Path):
    """Slip angle and efficiency against commanded γ at a few loads: the data (points), the base model and
    the diagnosed model (lines, held-out predictions). curves: {'loads': [...], 'panels': [(title, ylabel,
    [(load, γ, data, base, final)])]}."""
    plt = _plt()
    panels = curves["panels"]
    fig, axes = plt.subplots(1, len(panels), figsize=(7 * len(panels), 4.8), squeeze=False)
    cmap = plt.get_cmap("coolwarm")
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
    plt = _plt()
    fig, ax = plt.subplots(figsize=(8, 5))
    for m, row in table.items():
        ax.plot(ratios, row["error_pct"], "o-", label=f"{m} (mean |error| {row['mean_abs_error_pct']:.1f} %)")
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xscale("log")
    ax.set_xticks(ratios)
    ax.set_xticklabels([f"{q:g}" for q in ratios])
    ax.set_xlabel("requested speed ratio ω2/ω1")
    ax.set_ylabel("error (requested − achieved)/requested [%]")
    ax.set_title(f"resteering under τ⊥ = {load:+.2f} N·m (Brokowski Fig. 17)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save(fig, path, dpi=110)
def cad_picture(tri, ids, shade, colours, caption: str, path):
    """Shaded picture of a CAD assembly (cad.rasterise of its view mesh) with a caption, as PNG."""
    from cvtdesign.cad.assembly import rasterise

    plt = _plt()
    fig = plt.figure(figsize=(8, 8.4))
    ax = fig.add_axes((0, 0, 1, 8 / 8.4))
    ax.imshow(rasterise(tri, ids, shade, colours), interpolation="none")
    ax.axis("off")
    fig.text(0.5, 0.975, caption, ha="center", va="center", fontsize=10)
    save(fig, Path(path), dpi=100)
