"""`cvtdesign show`: a variant's layout before anything is solved: its ideal law, its rollers and a drawing."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from cvtdesign.core.geometry import FRAME, pose, steering_angle
from cvtdesign.core.kinematics import shaft_frame
from cvtdesign.io.output import make_folder
from cvtdesign.io.plots import layout_figure
from cvtdesign.io.variant import load_variant

DEFAULT_GAMMA = 45.0      # [deg] as export's: a machine that transmits (at γ = 0 the brake shaft stands still)


def direction_text(v) -> str:
    """A unit 3-vector as the frame names it equals and its components, e.g. '-c1 (0, 0.7071, -0.7071)'."""
    v = np.asarray(v, float).ravel()
    names = [("" if s > 0 else "-") + k for k, f in FRAME.items() for s in (1, -1) if np.allclose(v, s * f, atol=1e-9)]
    numbers = "(" + ", ".join(f"{x + 0.0:.4g}" for x in np.where(np.abs(v) < 1e-12, 0.0, v)) + ")"
    return f"{' = '.join(names)} {numbers}" if names else numbers


def roller_table(layout) -> Table:
    """The rollers as declared (at steering angle φ = 0): name, role, shaft, contact direction, axle,
    radius [mm], preload [N] and the fork each steered roller turns on."""
    table = Table(title=f"{layout.name}: rollers (sphere radius {1000 * float(layout.sphere_radius):.4g} mm; "
                        "directions from the sphere centre, at φ = 0)")
    for col, justify in (("roller", "left"), ("role", "left"), ("shaft", "right"), ("contact direction", "left"),
                         ("axle (positive spin)", "left"), ("radius [mm]", "right"), ("preload [N]", "right"),
                         ("fork", "left")):
        table.add_column(escape(col), justify=justify)
    for r in layout.rollers:
        n, a = pose(r, 0.0)
        fork = "—" if r.fork_axis is None else f"about {direction_text(r.fork_axis)}, ratio {r.fork_ratio:+.4g}"
        table.add_row(r.name, r.role, "—" if r.shaft is None else str(r.shaft), direction_text(n), direction_text(a),
                      f"{1000 * float(r.radius):.4g}", f"{float(r.preload):.4g}", fork)
    return table


def run(args):
    layout = load_variant(args.variant)
    frame = shaft_frame(layout)
    gamma_deg = DEFAULT_GAMMA if args.gamma is None else args.gamma
    gamma = np.radians(gamma_deg)
    phi = steering_angle(layout, gamma)
    figure = make_folder(args.out, kind="--out") / drawing_name(args.variant, args.gamma)
    replaced = figure.exists()
    layout_figure(layout, phi, gamma, figure)               # the file first, then the terminal
    console = Console(width=160)
    console.print(f"ideal law: {frame.law_text()}")
    ratio = float(frame.ideal_ratio(gamma))
    ratio = 0.0 if abs(ratio) < 1e-12 * frame.k else ratio     # round-off of a rotated layout's frame (8.7e-18)
    console.print(f"at commanded γ = {gamma_deg:g}°: steering angle φ = {np.degrees(phi):.3f}°, ideal "
                  f"ω2/ω1 = {ratio:.4g}")
    console.print(roller_table(layout))
    console.print(f"drawing: {figure}" + (" (replaced the earlier drawing of this file at this γ)" if replaced else ""))
    return 0


def drawing_name(variant, gamma_deg: float | None) -> str:
    """The drawing's file name, after the variant file (not the `name:` inside, which files may share):
    '<file stem>_layout.png' at the default γ (`gamma_deg` None), '<file stem>_layout_gamma30.png' at a γ
    given."""
    stem = Path(variant).stem
    return f"{stem}_layout.png" if gamma_deg is None else f"{stem}_layout_gamma{gamma_deg:g}.png"
