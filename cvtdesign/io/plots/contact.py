"""contact's figures: each roller's creep–force curves and its Hertz patch."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from cvtdesign.io.plots.base import figure_parts, save


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


def curve_label(group: list[str], records: dict) -> str:
    """The legend's name of a contact group's curves, with what they rest on: 'D1, D2 (drive): calibrated
    (library)' or '…: theory only' (cli.contact.curve_basis)."""
    basis = records[group[0]].get("curve_basis")
    return group_label(group, records) + (f": {basis}" if basis else "")


def contact_figures(name: str, records: dict, folder: Path, stem: str) -> list[Path]:
    """`cvtdesign contact`'s figures, `<stem>_contact_curves.png` and `<stem>_contact_patches.png` in `folder`
    (stem: the variant file's): the creep–force curves as the model runs them, at the calibrated compliance
    (`curve_<kind>`; one panel per creepage, their linear slope dotted, each contact's basis in the legend:
    'calibrated (library)', 'theory only', ...), where they differ the theory alone at the nominal moduli as a
    thin line of the same colour (`curve_<kind>_theory`); rollers with the same contact drawn once and named
    together, the others each in a colour, line style and marker of their own; the pure-spin moment against
    the pivoting moment μNℓ; and the contact patches drawn to scale [mm]. Returns the files written."""
    mpl = figure_parts()
    fig, axes = mpl.subplots(1, 4, figsize=(19, 4.6), layout="constrained")
    groups = same_contacts(records)
    thin = False
    for (key, xlabel, ylabel, what), ax in zip(CONTACT_CURVES, axes):
        for k, g in enumerate(groups):
            r = records[g[0]]
            colour, ls, marker = ROLLER_STYLES[k % len(ROLLER_STYLES)]
            s, f = np.array(r[key]).T
            ax.plot(s, f, ls=ls, color=colour, lw=1.6, marker=marker, ms=4, markevery=(3 * k, 12),
                    label=curve_label(g, records))
            ax.plot(s[:8], s[:8] * (f[1] / s[1]), ":", color=colour, lw=0.8)
            theory = r.get(f"{key}_theory")
            if theory is not None and not np.allclose(theory, r[key], rtol=1e-9, atol=1e-12):
                ax.plot(*np.array(theory).T, ls=ls, color=colour, lw=0.7, alpha=0.6)
                thin = True
        ax.axhline(1.0, color="k", lw=0.8)
        limit = "μNℓ (pivoting)" if key == "curve_spin_moment" else "μN (full slip)"
        ax.text(0.98, 1.01, limit, transform=ax.get_yaxis_transform(), fontsize=8, va="bottom", ha="right")
        ax.set(xlabel=xlabel, ylabel=ylabel, ylim=(0, 1.12), title=what)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, loc="lower right")
    fig.suptitle(f"{name}: creep–force curves and the spin moment at the preload, as the model runs them\n(FASTSIM, "
                 "Hertz traction bound, at the calibrated compliance; dotted: its linear slope"
                 + ("; thin: the theory alone at the nominal moduli" if thin else "") + ")\nrollers with the same "
                 "contact are drawn once, named together; curves on top of each other are contacts that behave alike")
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
