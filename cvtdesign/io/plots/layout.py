"""The layout drawing of `cvtdesign show`, and the optimum beside its base design in optimise's report: the
sphere and every roller in three orthographic views and one in perspective, lengths in mm.

What is drawn is what the machine has:
- each shaft (1: the motor's, 2: the brake's) as a line along the axle of each of its rollers, through the
  roller, and each roller labelled with the shaft it is on;
- each fork's axis from the sphere centre out through its own rollers, and each steering roller labelled
  with its fork (numbered as in `steering.forks`, from 1);
- Kim's frame vectors (d1, d2, d3, c1, c2, c3) only when the variant file names them: on a layout written
  in other directions they would mean nothing;
- the commanded sphere axis u(γ).

Labels are placed one after another where they overlap no label already placed and cover no arrow
(u(γ), the frame vectors, the front axles) and no front shaft (`plots.place_labels`, `plots.points_along`),
so that no two overlap at the drawing's default size and none hides what it names.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from cvtdesign.core.geometry import FRAME, pose, steering_angle
from cvtdesign.core.kinematics import shaft_frame
from cvtdesign.io.plots.base import figure_parts, place_labels, points_along, save

SHAFT_NAMES = {1: "motor shaft 1", 2: "brake shaft 2"}
SHAFT_COLOURS = {1: "tab:red", 2: "tab:green"}
ROLE_COLOURS = {"drive": "tab:blue", "follower": "tab:cyan", "steering": "tab:orange"}
FORK_COLOUR = "purple"
# orthographic views: (title, horizontal axis, vertical axis, axis pointing at the viewer, its sense)
VIEWS = (("top view (from +z)", 0, 1, 2, 1.0), ("front view (from −y)", 0, 2, 1, -1.0),
         ("side view (from +x)", 1, 2, 0, 1.0))


def roller_label(r: dict) -> str:
    """'D1\\ndrive · motor shaft 1', 'A_\\nfollower · motor shaft 1', 'S1\\nsteering · fork 1'."""
    on = SHAFT_NAMES.get(r["shaft"]) if r["shaft"] else (f"fork {r['fork_index']}" if r["fork_index"] else "fixed")
    return f"{r['name']}\n{r['role']} · {on}"


def layout_scene(layout, phi: float, gamma: float) -> dict:
    """What the layout drawing shows, lengths in mm: the sphere radius R; each roller at steering angle φ [rad]
    (rim circle, centre, contact normal, axle, role, shaft, its fork's axis and number); each fork (number,
    rollers, axis pointing from the sphere centre towards its rollers); Kim's frame vectors that the file
    names; the commanded sphere axis u(γ) at γ [rad] (kinematics.shaft_frame) and the ideal law."""
    frame = shaft_frame(layout)
    R = 1000 * float(layout.sphere_radius)
    fork_of = {n: k + 1 for k, f in enumerate(layout.forks) for n in f}
    rollers = []
    for r in layout.rollers:
        n, a = pose(r, phi)
        rad = 1000 * float(r.radius)
        centre = (R + rad) * n
        th = np.linspace(0, 2 * np.pi, 73)[:, None]
        rim = centre + rad * (np.cos(th) * n + np.sin(th) * np.cross(n, a))
        fork = None if r.fork_axis is None else np.asarray(r.fork_axis, float).ravel()
        rollers.append({"name": r.name, "role": r.role, "shaft": r.shaft, "radius": rad, "centre": centre,
                        "rim": rim, "normal": n, "axle": a, "fork": fork, "fork_index": fork_of.get(r.name)})
    drawn_forks = []
    for k, f in enumerate(layout.forks):
        own = [r for r in rollers if r["name"] in f]
        axis = own[0]["fork"]
        towards = np.mean([r["centre"] for r in own], axis=0)
        axis = axis if axis @ towards >= 0 else -axis
        reach = max(abs(r["centre"] @ axis) + r["radius"] for r in own)
        drawn_forks.append({"index": k + 1, "rollers": list(f), "axis": axis, "reach": max(reach, 1.2 * R)})
    return {"R": R, "rollers": rollers, "forks": drawn_forks,
            "frames": {k: FRAME[k] for k in layout.kim_vectors},
            "command": np.asarray(frame.axis(gamma), float).ravel(), "law": frame.law_text()}


def _arrow(ax, p0, p1, colour, lw=1.2, keep_off=None):
    """An arrow from p0 to p1 (data); `keep_off`: the list of lines the labels keep off, which it joins."""
    ax.annotate("", xy=p1, xytext=p0, arrowprops={"arrowstyle": "->", "color": colour, "lw": lw})
    if keep_off is not None:
        keep_off.append(np.array([p0, p1], float))


def shaft_line(r: dict) -> np.ndarray | None:
    """The shaft a drive or follower roller is on, drawn along its axle through it: (2, 3) end points [mm]."""
    if not r["shaft"]:
        return None
    half = 0.9 * r["radius"]
    return np.array([r["centre"] - half * r["axle"], r["centre"] + half * r["axle"]])


def _view(ax, scene, view, mpl) -> list:
    """One orthographic view of the scene: horizontal/vertical axes i, j; rollers whose centre lies behind
    the sphere's mid-plane drawn dashed and faint. Returns its labels for `plots.place_labels`: (anchor (x, y),
    text, colour, alpha), the front rollers' first; and the points along its arrows and front shafts, which
    the labels keep off (`plots.points_along`)."""
    title, i, j, k, sense = view
    R = scene["R"]
    ax.add_patch(mpl.Circle((0, 0), R, fc="lightgrey", ec="k", alpha=0.35, lw=1, zorder=1))
    for f in scene["forks"]:
        end = f["reach"] * f["axis"]
        ax.plot([0, end[i]], [0, end[j]], ":", color=FORK_COLOUR, lw=1.4, zorder=2)
    labels, behind, lines = [], [], []
    for name, v in scene["frames"].items():
        if np.hypot(v[i], v[j]) > 0.2:
            _arrow(ax, (0, 0), (0.6 * R * v[i], 0.6 * R * v[j]), "dimgrey", lw=0.8, keep_off=lines)
            behind.append(((0.68 * R * v[i], 0.68 * R * v[j]), name, "dimgrey", 1.0))
    u = scene["command"]
    if np.hypot(u[i], u[j]) > 0.1:
        _arrow(ax, (0, 0), (R * u[i], R * u[j]), "k", lw=2, keep_off=lines)
        labels.append(((1.1 * R * u[i], 1.1 * R * u[j]), "u(γ)", "k", 1.0))
    for r in sorted(scene["rollers"], key=lambda r: sense * r["centre"][k]):
        front = sense * r["centre"][k] >= -1e-9
        c, colour = r["centre"], ROLE_COLOURS[r["role"]]
        ax.fill(r["rim"][:, i], r["rim"][:, j], color=colour, alpha=0.35 if front else 0.1, zorder=3 if front else 0)
        ax.plot(r["rim"][:, i], r["rim"][:, j], "-" if front else "--", color=colour, lw=1.4 if front else 0.8,
                zorder=3 if front else 0)
        shaft = shaft_line(r)
        if shaft is not None:
            ax.plot(shaft[:, i], shaft[:, j], "-", color=SHAFT_COLOURS[r["shaft"]], lw=2.5 if front else 1.2,
                    alpha=1 if front else 0.4, solid_capstyle="butt", zorder=4 if front else 0)
            lines += [shaft[:, [i, j]]] if front else []
        tip = c + 0.7 * r["radius"] * r["axle"]
        if np.hypot(*(tip - c)[[i, j]]) > 0.15 * r["radius"]:
            _arrow(ax, (c[i], c[j]), (tip[i], tip[j]), "navy" if front else "lightsteelblue",
                   keep_off=lines if front else None)
        at = c + 1.25 * r["radius"] * r["normal"]
        (labels if front else behind).append(((at[i], at[j]), roller_label(r), "k", 1.0 if front else 0.55))
    ax.set_title(title, fontsize=10)
    ax.set_xlabel(f"{'xyz'[i]} [mm]")
    ax.set_ylabel(f"{'xyz'[j]} [mm]")
    ax.set_aspect("equal")
    ax.grid(alpha=0.2)
    return labels + behind, points_along(*lines, per_segment=12)


def _view_3d(ax, scene) -> list:
    """The scene in perspective: sphere wireframe, roller rims, axles, shafts, fork axes, the frame vectors
    the file names and u(γ). Returns the rollers' name labels (anchors in 3-D) for `plots.place_labels`."""
    R = scene["R"]
    a, b = np.meshgrid(np.linspace(0, 2 * np.pi, 25), np.linspace(0, np.pi, 13))
    ax.plot_wireframe(R * np.cos(a) * np.sin(b), R * np.sin(a) * np.sin(b), R * np.cos(b), color="grey", lw=0.3)
    labels = []
    for r in scene["rollers"]:
        c = r["centre"]
        ax.plot(*r["rim"].T, color=ROLE_COLOURS[r["role"]], lw=1.6)
        ax.quiver(*c, *(0.7 * r["radius"] * r["axle"]), color="navy", lw=1.2)
        shaft = shaft_line(r)
        if shaft is not None:
            ax.plot(*shaft.T, color=SHAFT_COLOURS[r["shaft"]], lw=2.5)
        labels.append((c + 1.25 * r["radius"] * r["normal"], r["name"], "k", 1.0))
    for name, v in scene["frames"].items():
        ax.quiver(0, 0, 0, *(0.6 * R * v), color="dimgrey", lw=0.8)
    for f in scene["forks"]:
        ax.plot(*np.outer([0, f["reach"]], f["axis"]).T, ":", color=FORK_COLOUR, lw=1.4)
    ax.quiver(0, 0, 0, *(R * scene["command"]), color="k", lw=2)
    reach = R + 2 * max(r["radius"] for r in scene["rollers"])
    step = 50 * np.ceil(reach / 150)            # three to five ticks an axis: their labels stay apart
    ticks = np.arange(-np.floor(reach / step), np.floor(reach / step) + 1) * step
    for axis in "xyz":
        getattr(ax, f"set_{axis}lim")(-reach, reach)
        getattr(ax, f"set_{axis}ticks")(ticks)
        getattr(ax, f"set_{axis}label")(f"{axis} [mm]", labelpad=10)
    ax.set_box_aspect((1, 1, 1))
    ax.set_title("3-D view", fontsize=10)
    return labels


def _legend(fig, scene, mpl):
    roles = [r["role"] for r in scene["rollers"]]
    handles = [mpl.Line2D([], [], color=c, lw=4, alpha=0.6, label=f"{role} roller") for role, c in ROLE_COLOURS.items()
               if role in roles]
    handles += [mpl.Line2D([], [], color=SHAFT_COLOURS[s], lw=2.5, label=f"{SHAFT_NAMES[s]} (through its rollers)")
                for s in (1, 2) if any(r["shaft"] == s for r in scene["rollers"])]
    handles += [mpl.Line2D([], [], color="navy", label="roller axle (positive spin)"),
                mpl.Line2D([], [], color="k", lw=2, label="commanded sphere axis u(γ)")]
    if scene["forks"]:
        handles.append(mpl.Line2D([], [], color=FORK_COLOUR, ls=":", lw=1.4, label="fork axis (out through its rollers)"))
    if scene["frames"]:
        handles.append(mpl.Line2D([], [], color="dimgrey", label=f"Kim's frame vectors ({' '.join(scene['frames'])})"))
    handles.append(mpl.Line2D([], [], color="grey", ls="--", label="behind the sphere (dashed, faint)"))
    fig.legend(handles=handles, loc="lower center", ncol=4, fontsize=8, frameon=False)


def layout_figure(layout, phi: float, gamma: float, path: Path) -> int:
    """The layout before anything is solved: a 3-D view and three orthogonal views (mm) of the sphere and
    every roller at its contact (rim circle, axle arrow, name, role and its shaft or fork; steered rollers
    turned to the steering angle φ [rad] that realises the commanded γ [rad]), the shafts through their
    rollers, the fork axes through theirs, the frame vectors the file names and the commanded sphere axis
    u(γ). Written to `path` (PNG); returns the number of labels left out for want of room (0 for the
    shipped variants)."""
    mpl = figure_parts()
    scene = layout_scene(layout, phi, gamma)
    fig = mpl.figure(figsize=(13, 13.4))
    ax3d = fig.add_subplot(2, 2, 1, projection="3d")
    labels = {ax3d: (_view_3d(ax3d, scene), ())}
    reach = scene["R"] + 2 * max(r["radius"] for r in scene["rollers"])
    for k, view in enumerate(VIEWS):
        ax = fig.add_subplot(2, 2, k + 2)
        labels[ax] = _view(ax, scene, view, mpl)
        ax.set_xlim(-reach, reach)
        ax.set_ylim(-reach, reach)
    _legend(fig, scene, mpl)
    fig.suptitle(f"{layout.name}: layout at commanded γ = {np.degrees(gamma):g}° (steering angle "
                 f"φ = {np.degrees(phi):.2f}°); ideal law {scene['law']}", fontsize=11)
    fig.subplots_adjust(left=0.06, right=0.97, bottom=0.1, top=0.94, wspace=0.2, hspace=0.18)
    left_out = sum(place_labels(fig, ax, ls, markers=off) for ax, (ls, off) in labels.items())
    save(fig, path, dpi=90)
    return left_out


def beside_figure(layouts: list[tuple[str, object]], gamma: float, path: Path) -> int:
    """Layouts side by side, a column each (its title, e.g. 'base design' or 'optimum: d = 31.94 mm'), in
    the three orthogonal views (a row each, so that the same view of each layout sits side by side, each view
    about half the figure's width) on one scale, at commanded γ [rad] (each at its own steering angle): the
    optimum of optimise's report beside its base design. Written to `path` (PNG); returns the number of
    labels left out for want of room."""
    mpl = figure_parts()
    scenes = [(title, layout_scene(L, steering_angle(L, gamma), gamma)) for title, L in layouts]
    reach = max(s["R"] + 2 * max(r["radius"] for r in s["rollers"]) for _, s in scenes)
    fig = mpl.figure(figsize=(6.6 * len(scenes) + 0.4, 20.5))
    columns = np.atleast_1d(fig.subfigures(1, len(scenes)))
    labels = {}
    for sub, (title, scene) in zip(columns, scenes):
        sub.suptitle(f"{title},\nat commanded γ = {np.degrees(gamma):g}°", fontsize=11)
        for k, view in enumerate(VIEWS):
            ax = sub.add_subplot(3, 1, k + 1)
            labels[ax] = _view(ax, scene, view, mpl)
            ax.set_xlim(-reach, reach)
            ax.set_ylim(-reach, reach)
        sub.subplots_adjust(left=0.1, right=0.98, bottom=0.06, top=0.935, hspace=0.14)
    _legend(fig, scenes[0][1], mpl)
    left_out = sum(place_labels(fig, ax, ls, markers=off) for ax, (ls, off) in labels.items())
    save(fig, path, dpi=90)
    return left_out
