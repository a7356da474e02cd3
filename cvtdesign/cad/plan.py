"""The assembly's parts from a variant's layout, in numpy (mm): what each part is, where it sits, its
dimensions and colour. No OpenCascade: `step` builds the solids from this plan.

Every part sits where the model's geometry puts it: `geometry.pose` at the steering angle φ that the
linkage's inverse kinematics gives for the commanded γ (`geometry.steering_angle_guess`, which seeds the
compiled model's Newton solve and agrees with it to ~1e-10 rad); nothing is placed by assembly constraints.
The model is SI [m]; the CAD is in millimetres.

Parts, named by role (the names in the STEP file; colours in COLOURS):

* `sphere`: radius R, centred at the origin of N.
* `<role>_<roller>` (`drive_A`, `follower_A_`, `steering_N1`: the roller's role and its name in the variant
  file): a crowned wheel. Its tread is, in the axial section, an arc of radius `crown_radius` whose apex
  (the rolling radius r) touches the sphere exactly at the contact point R·n (wheel centre (R + r)·n, axis
  the model's axle a); flat faces at ±width/2; a hub bore of radius AXLE_RADIUS + BORE_CLEARANCE.
* `axle_<roller>`: a rod of radius AXLE_RADIUS on the wheel's axis, through the bore with a real radial
  clearance; for drive and follower rollers a shaft STUB beyond each face, for steering rollers it spans
  the fork's arms (and touches them).
* `fork_<k>`, the k-th entry of `steering.forks` (counted from 1), turned with its rollers: per roller a
  yoke (two arms beside the wheel's faces holding the axle, joined by a bridge beyond the rim), a bent rod
  from each bridge up along the fork axis and across to a hub on it, and a pivot stem along the fork axis.
  Rollers on both sides of the sphere (two on one fork at ±its axis, or the box's four pole rollers on one
  fork) make a C: a far bridge's rod goes out beyond the fork's wheels, round the sphere and into the stem.
* `coupling_<follower>`: a flexible coupling shaft (a 6 mm tube) from the end face of the drive roller's
  axle on the same shaft to the end face of the follower's: straight on, radially out, round the outside of
  everything else (on a sphere COUPLING_CLEARANCE beyond the other parts) and back in. It shows which
  rollers are coupled; the gearing for a ratio other than 1 is not drawn.
* `frame`: a mounting plate, when the variant has a `frame` section (side, distance, thickness).
"""
from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

from cvtdesign.cad.shapes import (
    Ball,
    Block,
    Crowned,
    Pipe,
    Rod,
    perp,
    rounded_path,
    unit,
    vec3,
)
from cvtdesign.core.geometry import (
    pose,
    steering_angle,
)
from cvtdesign.core.layout import Layout
from cvtdesign.errors import InputError

# part dimensions [mm] that the variant does not fix
AXLE_RADIUS = 4.0          # axle (steel rod, 8 mm)
BORE_CLEARANCE = 0.5       # radial clearance between the axle and the wheel's hub bore
MIN_WALL = 2.0             # least wheel material between the bore and the tread's edge
STUB = 8.0                 # drive/follower shaft beyond each face of its wheel
FORK_GAP = 3.0             # fork arm to wheel face, and bridge to rim
FORK_THICKNESS = 5.0       # arms and bridge
FORK_ARM_HALF_WIDTH = 9.0  # arms and bridge, across the wheel's plane
FORK_BELOW_AXLE = 9.0      # arm length on the sphere's side of the axle
FORK_ROD = 4.0             # radius of the rods from a bridge to the hub
STEM_RADIUS = 5.0          # fork hub and pivot stem
STEM_LENGTH = 20.0         # pivot stem beyond the hub
FORK_BEND = 3 * FORK_ROD   # bend radius of those rods
COUPLING_RADIUS = 3.0      # flexible coupling shaft
COUPLING_BEND = 3 * COUPLING_RADIUS
COUPLING_LEAD = 12.0       # straight on from the axle's end face before the shaft bends outwards
COUPLING_STEP = np.radians(30)   # the route round the outside in chords of at most this angle
COUPLING_ROUTE_BEND = np.inf     # the route's corners as round as the chords allow: a circle again
COUPLING_CLEARANCE = 5.0   # the coupling's route runs this far outside every other part
FRAME_MARGIN = 20.0        # mounting plate beyond the assembly's outline

COLOURS = {                # RGB 0..1
    "sphere": (0.12, 0.20, 0.45),     # dark blue (bowling ball)
    "drive": (0.80, 0.15, 0.15),      # red
    "follower": (0.95, 0.55, 0.10),   # orange
    "steering": (0.20, 0.60, 0.25),   # green
    "axle": (0.55, 0.55, 0.58),       # steel grey
    "fork": (0.78, 0.78, 0.80),       # light grey (aluminium)
    "coupling": (0.15, 0.15, 0.15),   # black
    "frame": (0.85, 0.75, 0.55),      # tan
}


@dataclass
class Part:
    name: str
    kind: str                  # sphere | roller | axle | fork | coupling | frame
    colour: tuple
    prims: list
    field: str                 # the variant field a user would edit
    touches: tuple = ()        # parts it is built to touch (roller: sphere; fork, coupling: their axles)
    roller: str = ""           # a wheel's or an axle's roller: its name in the variant file

    def support(self, m):
        return np.max([p.support(m) for p in self.prims], axis=0)

    def reach(self):
        return max(p.reach() for p in self.prims)

    def bbox(self):
        boxes = np.array([p.box for p in self.prims])
        return np.array([boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)])


@dataclass
class Plan:
    layout: Layout
    gamma: float               # commanded γ [rad]
    phi: float                 # steering angle φ [rad] from the linkage's inverse kinematics
    parts: list = field(default_factory=list)

    def names(self):
        return [p.name for p in self.parts]

    def bbox(self):
        """Expected bounding box [[xmin, ymin, zmin], [xmax, ymax, zmax]] of the assembly [mm]."""
        b = np.array([p.bbox() for p in self.parts])
        return np.array([b[:, 0].min(axis=0), b[:, 1].max(axis=0)])

    def touching(self):
        return {frozenset((p.name, t)) for p in self.parts for t in p.touches}


def wheel_name(role: str, roller: str) -> str:
    """A roller's part name: its role and its name in the variant file (`drive_A`, `steering_N1`)."""
    return f"{role}_{roller}"


def named_by_role(name: str, layout: Layout) -> bool:
    """Whether a part name says what the part is: `sphere`, `frame`, `<role>_<roller>` with the roller's role
    in the variant, `axle_<roller>`, `coupling_<follower>` or `fork_<k>` (k = 1 … the number of forks); a
    roller's bare name is not."""
    roles = {r.name: r.role for r in layout.rollers}
    kind, _, rest = name.partition("_")
    forks = len(layout.forks)
    return name not in roles and (
        name in ("sphere", "frame") or roles.get(rest) == kind or (kind == "axle" and rest in roles)
        or (kind == "coupling" and roles.get(rest) == "follower")
        or (kind == "fork" and rest.isdigit() and 1 <= int(rest) <= forks))


def mm(v) -> float:
    """A length in metres as millimetres."""
    return 1000.0 * float(v)


def _forks(layout: Layout):
    """[(index, fork axis, [rollers])] of the variant's steering forks."""
    by_name = {r.name: r for r in layout.rollers}
    return [(i, unit(vec3(by_name[f[0]].fork_axis)), [by_name[n] for n in f]) for i, f in enumerate(layout.forks)]


def _wheel(layout, r, phi, R) -> Crowned:
    where = f"{layout.file}: rollers.{r.name}"
    radius, crown, width = mm(r.radius), mm(r.crown_radius), mm(r.width)
    if crown <= width / 2:
        raise InputError(f"{where}.crown_radius: a crown of {crown:g} mm cannot span the {width:g} mm wide "
                         f"wheel; expected more than width/2 = {width / 2:g} mm")
    n, a = (unit(v) for v in pose(r, phi))
    wheel = Crowned((R + radius) * n, a, n, radius, crown, width, AXLE_RADIUS + BORE_CLEARANCE)
    if wheel.rho(width / 2) < wheel.bore + MIN_WALL:
        raise InputError(f"{where}.radius: the wheel's tread edge ({wheel.rho(width / 2):.1f} mm from the axle) "
                         f"leaves no room for the {wheel.bore:g} mm hub bore; expected a larger radius or crown")
    return wheel


def _fork(index, axis, wheels, names, others, R) -> Part:
    """Yokes round each wheel, a bent rod from each bridge up (along the fork axis) and across to a hub on
    the fork axis, and a pivot stem along the axis. A bridge on the far side of the sphere from the hub, whose
    rod straight up would cut the sphere, gets one round it (`_round_the_sphere`); `others` are the other
    rollers' wheels, R the sphere's radius [mm]."""
    prims, bridges = [], []
    g, t, hw = FORK_GAP, FORK_THICKNESS, FORK_ARM_HALF_WIDTH
    for w in wheels:
        n, a, c = w.normal, w.axle, w.centre
        axes = np.array([n, np.cross(n, a), -a])            # right-handed: n × (n × a) = −a
        lo, hi = -(AXLE_RADIUS + FORK_BELOW_AXLE), w.radius + g + t
        for side in (-1, 1):
            centre = c + side * (w.width / 2 + g + t / 2) * a + (lo + hi) / 2 * n
            prims.append(Block(centre, axes, ((hi - lo) / 2, hw, t / 2)))
        bridges.append(c + (w.radius + g + t / 2) * n)
        prims.append(Block(bridges[-1], axes, (t / 2, hw, w.width / 2 + g + t)))
    k = axis if np.mean([b @ axis for b in bridges]) >= 0 else -axis
    off_axis = [b for b in bridges if np.linalg.norm(b - (b @ k) * k) > 1e-6]
    # the hub sits on the axis high enough that the rods to it clear every wheel of the fork
    H = max([max(b @ k for b in bridges) + t / 2, max(w.support(k) for w in wheels) + g + FORK_ROD]
            + [b @ k + FORK_BEND for b in off_axis])
    hub = H * k
    for b in bridges:
        beside = b - (b @ k) * k
        if b @ k < 0 and np.linalg.norm(beside) < R + FORK_GAP + FORK_ROD:    # straight up would cut the sphere
            prims.append(_round_the_sphere(b, k, H, wheels, others))
        elif np.linalg.norm(beside) > 1e-6:
            prims.append(Pipe(rounded_path([b, b + (H - b @ k) * k, hub], FORK_ROD, FORK_BEND)))
    prims.append(Rod(hub - (FORK_ROD + 1.0) * k, hub + STEM_LENGTH * k, STEM_RADIUS))
    return Part(f"fork_{index + 1}", "fork", COLOURS["fork"], prims, f"steering.forks[{index}]",
                tuple(f"axle_{n}" for n in names))


def _round_the_sphere(b, k, H, wheels, others) -> Pipe:
    """A rod from a bridge b on the far side of the sphere to the stem above the hub at H·k: out
    (perpendicular to the fork axis k, on the bridge's own side or, for a bridge on the axis, on the one of
    twelve sides farthest in angle from the other rollers' wheels) beyond every wheel of the fork, along k
    to the stem, and in."""
    u = perp(k)
    sides = [np.cos(a) * u + np.sin(a) * np.cross(k, u) for a in np.radians(np.arange(0, 360, 30))]
    beside = b - (b @ k) * k
    if np.linalg.norm(beside) > 1e-6:
        sides = [unit(beside)]
    away = [unit(c) for w in others if np.linalg.norm(c := w.centre - (w.centre @ k) * k) > 1e-6]
    e = min(sides, key=lambda s: max([s @ c for c in away], default=-1.0))
    rho = max(w.reach() for w in wheels) + FORK_GAP + FORK_ROD
    # it ends in the stem, above the other rods' ends and beside the axis: rods that met end to end, or ran
    # along one line, made OpenCascade's fusion of the fork empty
    top = H + STEM_LENGTH / 2
    return Pipe(rounded_path([b, (b @ k) * k + rho * e, top * k + rho * e, top * k + FORK_ROD * e], FORK_ROD,
                             FORK_BEND))


def _coupling(follower, drive, axles, wheels, r_out, vias) -> Part:
    """Flexible shaft from the end face of the drive roller's axle (its +axle end) to that of the follower's:
    straight on along the axle, radially out to radius r_out, round the outside on that sphere (when the two
    ends face away from each other, over the side perpendicular to both that is farthest from the other
    couplings' routes) in chords of at most COUPLING_STEP, and back in; corners rounded (COUPLING_BEND)."""
    ends = []
    for name in (drive, follower):
        e, a = axles[name].p1, wheels[name].axle
        ends.append((e, e + COUPLING_LEAD * a, r_out * unit(e + COUPLING_LEAD * a)))
    (e0, q0, p), (e1, q1, q) = ends
    u, v = unit(p), unit(q)
    if u @ v > -0.5:
        via = unit(u + v)
    else:
        c = np.cross(u, v)
        c = unit(c) if np.linalg.norm(c) > 1e-9 else perp(u)
        via = max((c, -c), key=lambda d: min([np.arccos(np.clip(d @ o, -1, 1)) for o in vias], default=0.0))
    vias.append(via)
    V = r_out * via
    # the circle through p, V, q lies on the sphere of radius r_out; its centre is the origin's projection
    m = unit(np.cross(V - p, q - p))
    o = (p @ m) * m
    e1_, e2_ = unit(p - o), np.cross(m, unit(p - o))
    ang = lambda x: np.arctan2((x - o) @ e2_, (x - o) @ e1_) % (2 * np.pi)
    turn, sense = ang(q), 1.0
    if ang(V) > turn:                       # V lies on the other arc from p to q: go round the other way
        turn, sense = 2 * np.pi - turn, -1.0
    steps = int(np.ceil(turn / COUPLING_STEP))
    rc = float(np.linalg.norm(p - o))
    arc = [o + rc * (np.cos(sense * th) * e1_ + np.sin(sense * th) * e2_) for th in np.linspace(0, turn, steps + 1)]
    path = [e0, q0, *arc, q1, e1]
    bends = [COUPLING_BEND] + [COUPLING_ROUTE_BEND] * len(arc) + [COUPLING_BEND]
    return Part(f"coupling_{follower}", "coupling", COLOURS["coupling"],
                [Pipe(rounded_path(path, COUPLING_RADIUS, bends))], f"rollers.{follower}.shaft",
                (f"axle_{drive}", f"axle_{follower}"))


def _frame_spec(layout: Layout):
    """(side (unit), distance [mm], thickness [mm]) of the variant's mounting plate, or None."""
    f = layout.frame
    return None if f is None else (unit(vec3(f.side)), mm(f.distance), mm(f.thickness))


def _frame(layout: Layout, parts, side, dist, thick) -> Part:
    """Mounting plate perpendicular to `side`, its near face `dist` [mm] from the sphere centre, covering the
    assembly's outline with FRAME_MARGIN; refused if any part reaches it."""
    reach = {p.name: float(p.support(side)) for p in parts}
    worst = max(reach, key=reach.get)
    if dist < reach[worst] + 1.0:
        raise InputError(f"{layout.file}: frame.distance: the plate at {dist:g} mm would cut part {worst} (it reaches "
                         f"{reach[worst]:.1f} mm towards the plate); expected at least {reach[worst] + 1:.1f} mm")
    e1 = perp(side)
    e2 = np.cross(side, e1)
    lo = [-max(p.support(-e) for p in parts) - FRAME_MARGIN for e in (e1, e2)]
    hi = [max(p.support(e) for p in parts) + FRAME_MARGIN for e in (e1, e2)]
    centre = (dist + thick / 2) * side + (lo[0] + hi[0]) / 2 * e1 + (lo[1] + hi[1]) / 2 * e2
    block = Block(centre, np.array([e1, e2, side]), ((hi[0] - lo[0]) / 2, (hi[1] - lo[1]) / 2, thick / 2))
    return Part("frame", "frame", COLOURS["frame"], [block], "frame")


@contextmanager
def _drawn(layout: Layout, field: str, name: str):
    """A part the layout asks for that cannot be drawn (a rod's corner tighter than the rod: shapes.rounded_path)
    is one InputError line naming its field."""
    try:
        yield
    except RuntimeError as e:
        raise InputError(f"{layout.file}: {field}: part {name} cannot be drawn ({e}); expected a layout whose parts "
                         "can be drawn (docs/cad.md)") from None


def plan(layout: Layout, gamma_deg: float = 45.0) -> Plan:
    """The assembly's parts at commanded γ [deg], in mm, from the layout (no cadquery)."""
    gamma = np.radians(gamma_deg)
    phi = steering_angle(layout, gamma)
    frame = _frame_spec(layout)
    R = mm(layout.sphere_radius)
    out = Plan(layout, gamma, phi)
    out.parts.append(Part("sphere", "sphere", COLOURS["sphere"], [Ball(np.zeros(3), R)], "sphere"))
    wheels, axles = {}, {}
    for r in layout.rollers:
        w = wheels[r.name] = _wheel(layout, r, phi, R)
        out.parts.append(Part(wheel_name(r.role, r.name), "roller", COLOURS[r.role], [w], f"rollers.{r.name}",
                              ("sphere",), r.name))
    for r in layout.rollers:
        w = wheels[r.name]
        ext = w.width / 2 + (FORK_GAP if r.role == "steering" else STUB)
        axles[r.name] = Rod(w.centre - ext * w.axle, w.centre + ext * w.axle, AXLE_RADIUS)
        out.parts.append(Part(f"axle_{r.name}", "axle", COLOURS["axle"], [axles[r.name]], f"rollers.{r.name}",
                              roller=r.name))
    for i, axis, rs in _forks(layout):
        names = [r.name for r in rs]
        with _drawn(layout, f"steering.forks[{i}]", f"fork_{i + 1}"):
            out.parts.append(_fork(i, axis, [wheels[n] for n in names], names,
                                   [w for n, w in wheels.items() if n not in names], R))
    followers = [r for r in layout.rollers if r.role == "follower"]
    if followers:
        # chords of COUPLING_STEP dip inside the sphere they are inscribed in by a factor cos(step/2)
        r_out = (max(p.reach() for p in out.parts) + COUPLING_CLEARANCE + COUPLING_RADIUS) / np.cos(COUPLING_STEP / 2)
        vias = [] if frame is None else [frame[0]]          # keep the couplings off the plate's side
        for f in followers:
            drive = next(r for r in layout.rollers if r.role == "drive" and r.shaft == f.shaft)
            with _drawn(layout, f"rollers.{f.name}.shaft", f"coupling_{f.name}"):
                out.parts.append(_coupling(f.name, drive.name, axles, wheels, r_out, vias))
    if frame is not None:
        out.parts.append(_frame(layout, out.parts, *frame))
    return out
