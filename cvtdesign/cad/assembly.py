"""CAD export for mechanical review: a variant's assembly as STEP (named, coloured parts), an SVG line
drawing and a shaded PNG, with geometric checks of the written file (`cvtdesign export`).

Every part sits where the model's geometry puts it: `geometry.pose` at the steering angle φ that the
linkage's inverse kinematics gives for the commanded γ (`geometry.steering_angle_guess`, which seeds the
compiled model's Newton solve and agrees with it to ~1e-10 rad); nothing is placed by assembly constraints.
The model is SI [m]; the CAD is in millimetres.

Each part is first described in numpy by primitives (`Ball`, `Rod`, `Block`, `Crowned`, `ArcTube`, `Pipe`;
mm). A primitive has an exact support function h(m) = max x·m, from which the expected bounding box, the
fork heights, the frame clearance and a fast clearance screen (`hull_gap`) follow from the layout alone,
and it builds its OpenCascade solid. cadquery is imported only inside the functions that build, write or
check solids (`_cq`), so `compare`, the model, `optimise` and `study` never load it.

Parts (names as in the STEP file; colours in COLOURS):

* `sphere`: radius R, centred at the origin of N.
* each roller, named as in the variant: a crowned wheel. Its tread is, in the axial section, an arc of
  radius `crown_radius` whose apex (the rolling radius r) touches the sphere exactly at the contact point
  R·n (wheel centre (R + r)·n, axis the model's axle a); flat faces at ±width/2; a hub bore of radius
  AXLE_RADIUS + BORE_CLEARANCE.
* `axle_<roller>`: a rod of radius AXLE_RADIUS on the wheel's axis, through the bore with a real radial
  clearance; for drive and follower rollers a shaft STUB beyond each face, for steering rollers it spans
  the fork's arms (and touches them).
* `fork_<rollers joined by +>`, one per `steering.forks` entry, turned with its rollers: per roller a yoke
  (two arms beside the wheel's faces holding the axle, joined by a bridge beyond the rim), a bent rod from
  each bridge up along the fork axis and across to a hub on it, and a pivot stem along the fork axis.
* `coupling_<follower>`: a flexible coupling shaft (a 6 mm tube) from the end face of the drive roller's
  axle on the same shaft to the end face of the follower's: straight on, radially out, round the outside of
  everything else (on a sphere COUPLING_CLEARANCE beyond the other parts) and back in. It shows which
  rollers are coupled; the gearing for a ratio other than 1 is not drawn.
* `frame`: a mounting plate, when the variant has a `frame` section (side, distance, thickness).
"""
from __future__ import annotations

import functools
import itertools
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from cvtdesign.core.geometry import pose, steering_angle_guess, steering_data
from cvtdesign.io.output import make_folder, staged
from cvtdesign.errors import InputError
from cvtdesign.io.units import to_si
from cvtdesign.core.layout import Layout
from cvtdesign.io.variant import load_variant, vector

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

# checks
TOUCH_TOL = 1e-3           # [mm] a roller touches the sphere: min distance below this
VOLUME_TOL = 1e-3          # [mm³] intersection volume counted as interference above this
BBOX_TOL = 1e-3            # [mm] STEP bounding box against the one computed from the layout
CONTACT_TOL = 1e-3         # [mm] the wheel touches the sphere at R·n

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
VIEW = (1.0, -0.3, 0.8)     # projection direction (towards the viewer) of the SVG and PNG, z drawn upwards


# --- primitives (numpy, mm) ------------------------------------------------------------------------------

def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def _vec3(v) -> np.ndarray:
    """A numeric 3-vector (numpy array, list or CasADi DM) as a flat numpy array."""
    return np.asarray(v.full() if hasattr(v, "full") else v, float).ravel()


def _perp(v):
    """A unit vector perpendicular to unit v."""
    e = np.eye(3)[np.argmin(np.abs(v))]
    return _unit(np.cross(v, e))


class _Prim:
    """Shared by the primitives. `support(m)` is max over the body of x·m [mm] for a unit direction m (3,)
    or for many (K, 3) at once; `box` the bounding box [[min], [max]] [mm] from it."""

    @functools.cached_property
    def box(self):
        e = np.concatenate([-np.eye(3), np.eye(3)])
        h = self.support(e)
        return np.array([-h[:3], h[3:]])

    @functools.cached_property
    def pieces(self):
        """Convex pieces for the clearance screen (an arc tube in sub-arcs of at most 10°, a pipe its segments')."""
        return [self]


def _root(x):
    return np.sqrt(np.clip(x, 0.0, None))


@dataclass(frozen=True)
class Ball(_Prim):
    centre: np.ndarray
    radius: float

    def support(self, m):
        return m @ self.centre + self.radius

    def reach(self):
        return float(np.linalg.norm(self.centre) + self.radius)

    def solid(self, cq):
        return cq.Solid.makeSphere(self.radius, cq.Vector(*self.centre), angleDegrees1=-90, angleDegrees2=90)


@dataclass(frozen=True)
class Rod(_Prim):
    """Flat-ended cylinder from p0 to p1."""
    p0: np.ndarray
    p1: np.ndarray
    radius: float

    def support(self, m):
        a = _unit(self.p1 - self.p0)
        return np.maximum(m @ self.p0, m @ self.p1) + self.radius * _root(1 - (m @ a) ** 2)

    def reach(self):
        return float(max(np.linalg.norm(self.p0), np.linalg.norm(self.p1)) + self.radius)

    def solid(self, cq):
        d = self.p1 - self.p0
        return cq.Solid.makeCylinder(self.radius, float(np.linalg.norm(d)), cq.Vector(*self.p0), cq.Vector(*_unit(d)))


@dataclass(frozen=True)
class Block(_Prim):
    """Box with centre, right-handed unit axes (rows) and half sizes along them."""
    centre: np.ndarray
    axes: np.ndarray
    half: tuple

    def support(self, m):
        return m @ self.centre + np.abs(m @ self.axes.T) @ np.asarray(self.half)

    def reach(self):
        return float(np.linalg.norm(self.centre) + np.linalg.norm(self.half))

    def solid(self, cq):
        h = self.half
        box = cq.Solid.makeBox(2 * h[0], 2 * h[1], 2 * h[2], cq.Vector(-h[0], -h[1], -h[2]))
        return box.moved(cq.Location(cq.Plane(tuple(self.centre), tuple(self.axes[0]), tuple(self.axes[2]))))


@dataclass(frozen=True)
class Crowned(_Prim):
    """Crowned wheel: revolved about the axle a through the centre; in the axial section the tread is an
    arc of radius `crown` with its apex at the rolling radius, ρ(s) = radius − crown + √(crown² − s²) for
    |s| ≤ width/2; flat faces; hub bore of radius `bore`. `normal` points from the sphere to the wheel."""
    centre: np.ndarray
    axle: np.ndarray
    normal: np.ndarray
    radius: float
    crown: float
    width: float
    bore: float

    def rho(self, s):
        return self.radius - self.crown + np.sqrt(self.crown ** 2 - s ** 2)

    def support(self, m):
        # max over s of c·m + s (a·m) + ρ(s) √(1 − (a·m)²); ρ is concave, the stationary point is s = crown·(a·m)
        am = m @ self.axle
        s = np.clip(self.crown * am, -self.width / 2, self.width / 2)
        return m @ self.centre + s * am + self.rho(s) * _root(1 - am * am)

    def reach(self):
        return float(np.linalg.norm(self.centre) + np.hypot(self.radius, self.width / 2))

    def solid(self, cq):
        wheel = _wheel_solid(cq, self.radius, self.crown, self.width, self.bore)
        # local x (where the apex is) → −normal, towards the sphere; local z → axle
        return wheel.moved(cq.Location(cq.Plane(tuple(self.centre), tuple(-self.normal), tuple(self.axle))))


@functools.lru_cache(maxsize=32)
def _wheel_solid(cq, radius, crown, width, bore):
    """A crowned wheel about the local z axis, its tread's apex on the local +x axis (one per size)."""
    h = width / 2
    edge = radius - crown + np.sqrt(crown ** 2 - h ** 2)
    # axial section in the local XZ plane (x = radial, z = axial), revolved about local z
    section = (cq.Workplane("XZ").moveTo(bore, -h).lineTo(edge, -h)
               .threePointArc((radius, 0.0), (edge, h)).lineTo(bore, h).close())
    return section.revolve(360, (0, 0, 0), (0, 1, 0)).val()


@dataclass(frozen=True)
class ArcTube(_Prim):
    """Tube of radius `radius` round a circular arc: centre o, unit axis m, from `start` by `angle` [rad]
    (right-handed about m)."""
    centre: np.ndarray
    axis: np.ndarray
    start: np.ndarray
    angle: float
    radius: float

    @functools.cached_property
    def _frame(self):
        e1 = self.start - self.centre
        rc = float(np.linalg.norm(e1))
        e1 = e1 / rc
        return rc, e1, np.cross(self.axis, e1)

    def support(self, m):
        # c·m + rc·C cos δ + ρ √(1 − C² sin² δ) decreases in |δ| = |θ − θ0| (rc > ρ): take the arc's θ nearest θ0
        rc, e1, e2 = self._frame
        A, B = m @ e1, m @ e2
        C, th0 = np.hypot(A, B), np.arctan2(B, A) % (2 * np.pi)
        th = np.where(th0 <= self.angle, th0, np.where(th0 - self.angle < 2 * np.pi - th0, self.angle, 0.0))
        d = th - th0
        return m @ self.centre + rc * C * np.cos(d) + self.radius * _root(1 - (C * np.sin(d)) ** 2)

    def reach(self):
        rc, _, _ = self._frame
        return float(np.linalg.norm(self.centre) + rc + self.radius)

    @functools.cached_property
    def pieces(self):
        n = int(np.ceil(self.angle / np.radians(10)))
        rc, e1, e2 = self._frame
        turn = lambda i: self.centre + rc * (np.cos(i * self.angle / n) * e1 + np.sin(i * self.angle / n) * e2)
        return [ArcTube(self.centre, self.axis, turn(i), self.angle / n, self.radius) for i in range(n)]

    def solid(self, cq):
        rc, e1, e2 = self._frame
        circle = cq.Wire.makeCircle(self.radius, cq.Vector(*self.start), cq.Vector(*e2))
        face = cq.Face.makeFromWires(circle)
        return cq.Solid.revolve(face, float(np.degrees(self.angle)), cq.Vector(*self.centre),
                                cq.Vector(*(self.centre + self.axis)))


@dataclass(frozen=True)
class Pipe(_Prim):
    """A tube swept along a tangent-continuous path of straight (`Rod`) and bent (`ArcTube`) segments of the
    same radius: one sweep, no booleans. Its support is the segments' (their end discs coincide)."""
    segments: tuple

    def support(self, m):
        return np.max([seg.support(m) for seg in self.segments], axis=0)

    def reach(self):
        return max(seg.reach() for seg in self.segments)

    @functools.cached_property
    def pieces(self):
        return [q for seg in self.segments for q in seg.pieces]

    def solid(self, cq):
        edges = []
        for seg in self.segments:
            if isinstance(seg, Rod):
                edges.append(cq.Edge.makeLine(cq.Vector(*seg.p0), cq.Vector(*seg.p1)))
            else:
                rc, e1, e2 = seg._frame
                pt = lambda th: cq.Vector(*(seg.centre + rc * (np.cos(th) * e1 + np.sin(th) * e2)))
                edges.append(cq.Edge.makeThreePointArc(pt(0.0), pt(seg.angle / 2), pt(seg.angle)))
        first = self.segments[0]
        start, tangent = (first.p0, _unit(first.p1 - first.p0)) if isinstance(first, Rod) else (first.start, first._frame[2])
        circle = cq.Wire.makeCircle(first.radius, cq.Vector(*start), cq.Vector(*tangent))
        return cq.Solid.sweep(circle, [], cq.Wire.assembleEdges(edges), makeSolid=True)


def rounded_path(points, radius, bend):
    """Segments of a tube of `radius` along the polyline `points` [mm] with corner i rounded by an arc of
    radius bend[i] (or `bend` at every corner; smaller where the segments are short, never below
    1.5 × radius)."""
    pts = [np.asarray(q, float) for i, q in enumerate(points) if i == 0 or np.linalg.norm(q - points[i - 1]) > 1e-9]
    dirs = [_unit(b - a) for a, b in zip(pts, pts[1:])]
    lengths = [float(np.linalg.norm(b - a)) for a, b in zip(pts, pts[1:])]
    turns = [float(np.arccos(np.clip(d0 @ d1, -1, 1))) for d0, d1 in zip(dirs, dirs[1:])]
    # room for each corner's tangent length: a segment is shared by the corners at its two ends
    share = lambda i: lengths[i] / (1 if i in (0, len(lengths) - 1) else 2)
    bends = []
    for i, th in enumerate(turns):
        if th < 1e-6:
            bends.append(0.0)
            continue
        rb = min(np.broadcast_to(bend, len(turns))[i], min(share(i), share(i + 1)) / np.tan(th / 2))
        if rb < 1.5 * radius:
            raise RuntimeError(f"path corner {i + 1} too tight for a {radius:g} mm tube")
        bends.append(rb)
    segments, here = [], pts[0]
    for i in range(len(turns) + 1):
        end = pts[i + 1]
        if i < len(turns) and bends[i] > 0:
            cut = bends[i] * np.tan(turns[i] / 2)
            a, b = end - cut * dirs[i], end + cut * dirs[i + 1]
            if np.linalg.norm(a - here) > 1e-9:
                segments.append(Rod(here, a, radius))
            inward = _unit(dirs[i + 1] - dirs[i])                     # towards the bend's centre
            centre = a + bends[i] * _unit(inward - (inward @ dirs[i]) * dirs[i])
            axis = _unit(np.cross(a - centre, dirs[i]))
            segments.append(ArcTube(centre, axis, a, turns[i], radius))
            here = b
        elif i == len(turns):
            segments.append(Rod(here, end, radius))
    return tuple(segments)


@dataclass
class Part:
    name: str
    kind: str                  # sphere | roller | axle | fork | coupling | frame
    colour: tuple
    prims: list
    field: str                 # the variant field a user would edit
    touches: tuple = ()        # parts it is built to touch (roller: sphere; fork, coupling: their axles)

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


# --- the plan: parts from the layout, in numpy --------------------------------------------------------------

def _mm(v) -> float:
    return 1000.0 * float(v)


def steering_angle(layout: Layout, gamma: float) -> float:
    """Steering angle φ [rad] at which every steered roller rolls without lateral slip about the commanded
    axis at γ [rad]: the linkage's inverse kinematics as the model seeds and solves it (`steering_angle_guess`
    refines a scan to ~1e-10 rad; the model's Newton solve starts there). γ must be finite and within the
    variant's envelope.gamma range (the command line's --gamma)."""
    lo, hi = float(np.min(layout.gamma_grid)), float(np.max(layout.gamma_grid))
    if not (np.isfinite(gamma) and lo - 1e-12 <= gamma <= hi + 1e-12):
        raise InputError(f"{layout.file}: --gamma: γ = {np.degrees(gamma):g}° is outside the variant's envelope.gamma "
                         f"range {np.degrees(lo):g}..{np.degrees(hi):g}°; expected a --gamma in that range")
    phi, misfit = steering_angle_guess(*steering_data(layout), np.array([gamma]))
    if misfit[0] > 1e-6:
        raise InputError(f"{layout.file}: steering.forks: the linkage cannot reach γ = {np.degrees(gamma):g}° "
                         f"(misfit {misfit[0]:.2g}); expected a --gamma the steering rollers can realise")
    return float(phi[0])


def _forks(layout: Layout):
    """[(index, fork axis, [rollers])] of the variant's steering forks."""
    by_name = {r.name: r for r in layout.rollers}
    return [(i, _unit(_vec3(by_name[f.rollers[0]].fork_axis)), [by_name[n] for n in f.rollers])
            for i, f in enumerate(layout.spec.steering.forks)]


def _wheel(layout, r, phi, R) -> Crowned:
    where = f"{layout.file}: rollers.{r.name}"
    radius, crown, width = _mm(r.radius), _mm(r.crown_radius), _mm(r.width)
    if crown <= width / 2:
        raise InputError(f"{where}.crown_radius: a crown of {crown:g} mm cannot span the {width:g} mm wide "
                         f"wheel; expected more than width/2 = {width / 2:g} mm")
    n, a = (_unit(v) for v in pose(r, phi))
    wheel = Crowned((R + radius) * n, a, n, radius, crown, width, AXLE_RADIUS + BORE_CLEARANCE)
    if wheel.rho(width / 2) < wheel.bore + MIN_WALL:
        raise InputError(f"{where}.radius: the wheel's tread edge ({wheel.rho(width / 2):.1f} mm from the axle) "
                         f"leaves no room for the {wheel.bore:g} mm hub bore; expected a larger radius or crown")
    return wheel


def _fork(index, axis, wheels, names) -> Part:
    """Yokes round each wheel, a bent rod from each bridge up (along the fork axis) and across to a hub on
    the fork axis, and a pivot stem along the axis."""
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
    for b in off_axis:
        prims.append(Pipe(rounded_path([b, b + (H - b @ k) * k, hub], FORK_ROD, FORK_BEND)))
    prims.append(Rod(hub - (FORK_ROD + 1.0) * k, hub + STEM_LENGTH * k, STEM_RADIUS))
    return Part("fork_" + "+".join(names), "fork", COLOURS["fork"], prims, f"steering.forks[{index}]",
                tuple(f"axle_{n}" for n in names))


def _coupling(follower, drive, axles, wheels, r_out, vias) -> Part:
    """Flexible shaft from the end face of the drive roller's axle (its +axle end) to that of the follower's:
    straight on along the axle, radially out to radius r_out, round the outside on that sphere (when the two
    ends face away from each other, over the side perpendicular to both that is farthest from the other
    couplings' routes) in chords of at most COUPLING_STEP, and back in; corners rounded (COUPLING_BEND)."""
    ends = []
    for name in (drive, follower):
        e, a = axles[name].p1, wheels[name].axle
        ends.append((e, e + COUPLING_LEAD * a, r_out * _unit(e + COUPLING_LEAD * a)))
    (e0, q0, p), (e1, q1, q) = ends
    u, v = _unit(p), _unit(q)
    if u @ v > -0.5:
        via = _unit(u + v)
    else:
        c = np.cross(u, v)
        c = _unit(c) if np.linalg.norm(c) > 1e-9 else _perp(u)
        via = max((c, -c), key=lambda d: min([np.arccos(np.clip(d @ o, -1, 1)) for o in vias], default=0.0))
    vias.append(via)
    V = r_out * via
    # the circle through p, V, q lies on the sphere of radius r_out; its centre is the origin's projection
    m = _unit(np.cross(V - p, q - p))
    o = (p @ m) * m
    e1_, e2_ = _unit(p - o), np.cross(m, _unit(p - o))
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
    spec = getattr(layout.spec, "frame", None)
    if spec is None:
        return None
    where, names = f"{layout.file}: frame", layout.parameters
    side = _unit(_vec3(vector(spec.side, f"{where}.side", names)))
    dist = _mm(to_si(spec.distance, "length", f"{where}.distance", names))
    thick = _mm(to_si(spec.thickness, "length", f"{where}.thickness", names))
    if not thick > 0:
        raise InputError(f"{where}.thickness: expected a positive thickness, got {thick:g} mm")
    return side, dist, thick


def _frame(layout: Layout, parts, side, dist, thick) -> Part:
    """Mounting plate perpendicular to `side`, its near face `dist` [mm] from the sphere centre, covering the
    assembly's outline with FRAME_MARGIN; refused if any part reaches it."""
    reach = {p.name: float(p.support(side)) for p in parts}
    worst = max(reach, key=reach.get)
    if dist < reach[worst] + 1.0:
        raise InputError(f"{layout.file}: frame.distance: the plate at {dist:g} mm would cut part {worst} (it reaches "
                         f"{reach[worst]:.1f} mm towards the plate); expected at least {reach[worst] + 1:.1f} mm")
    e1 = _perp(side)
    e2 = np.cross(side, e1)
    lo = [-max(p.support(-e) for p in parts) - FRAME_MARGIN for e in (e1, e2)]
    hi = [max(p.support(e) for p in parts) + FRAME_MARGIN for e in (e1, e2)]
    centre = (dist + thick / 2) * side + (lo[0] + hi[0]) / 2 * e1 + (lo[1] + hi[1]) / 2 * e2
    block = Block(centre, np.array([e1, e2, side]), ((hi[0] - lo[0]) / 2, (hi[1] - lo[1]) / 2, thick / 2))
    return Part("frame", "frame", COLOURS["frame"], [block], "frame")


def plan(layout: Layout, gamma_deg: float = 45.0) -> Plan:
    """The assembly's parts at commanded γ [deg], in mm, from the layout (no cadquery)."""
    gamma = np.radians(gamma_deg)
    phi = steering_angle(layout, gamma)
    frame = _frame_spec(layout)
    R = _mm(layout.sphere_radius)
    out = Plan(layout, gamma, phi)
    out.parts.append(Part("sphere", "sphere", COLOURS["sphere"], [Ball(np.zeros(3), R)], "sphere"))
    wheels, axles = {}, {}
    for r in layout.rollers:
        w = wheels[r.name] = _wheel(layout, r, phi, R)
        out.parts.append(Part(r.name, "roller", COLOURS[r.role], [w], f"rollers.{r.name}", ("sphere",)))
    for r in layout.rollers:
        w = wheels[r.name]
        ext = w.width / 2 + (FORK_GAP if r.role == "steering" else STUB)
        axles[r.name] = Rod(w.centre - ext * w.axle, w.centre + ext * w.axle, AXLE_RADIUS)
        out.parts.append(Part(f"axle_{r.name}", "axle", COLOURS["axle"], [axles[r.name]], f"rollers.{r.name}"))
    for i, axis, rs in _forks(layout):
        out.parts.append(_fork(i, axis, [wheels[r.name] for r in rs], [r.name for r in rs]))
    followers = [r for r in layout.rollers if r.role == "follower"]
    if followers:
        # chords of COUPLING_STEP dip inside the sphere they are inscribed in by a factor cos(step/2)
        r_out = (max(p.reach() for p in out.parts) + COUPLING_CLEARANCE + COUPLING_RADIUS) / np.cos(COUPLING_STEP / 2)
        vias = [] if frame is None else [frame[0]]          # keep the couplings off the plate's side
        for f in followers:
            drive = next(r for r in layout.rollers if r.role == "drive" and r.shaft == f.shaft)
            out.parts.append(_coupling(f.name, drive.name, axles, wheels, r_out, vias))
    if frame is not None:
        out.parts.append(_frame(layout, out.parts, *frame))
    return out


# --- solids (cadquery, imported here only) ----------------------------------------------------------------

def _cq():
    import cadquery as cq

    return cq


def build(p: Plan) -> tuple[dict, dict]:
    """({part name: cadquery Solid}, {part name: [Solid per primitive]}) in mm; a part's primitives fused."""
    cq = _cq()
    shapes, pieces = {}, {}
    for part in p.parts:
        solids = pieces[part.name] = [prim.solid(cq) for prim in part.prims]
        shape = solids[0] if len(solids) == 1 else solids[0].fuse(*solids[1:]).clean()
        if len(shape.Solids()) != 1:
            raise RuntimeError(f"part {part.name}: its primitives fused into {len(shape.Solids())} solids")
        shapes[part.name] = shape.Solids()[0]
    return shapes, pieces


def _boxes_overlap(a, b, margin):
    return bool(np.all(a[0] - margin <= b[1]) and np.all(b[0] - margin <= a[1]))


def _candidate_pairs(p: Plan, margin: float):
    """Pairs of parts whose bounding boxes (from the layout) come within `margin` [mm] of each other."""
    boxes = {part.name: part.bbox() for part in p.parts}
    return [(a, b) for a, b in itertools.combinations(p.parts, 2) if _boxes_overlap(boxes[a.name], boxes[b.name], margin)]


def _directions(n=256):
    """n unit vectors spread evenly over the sphere (Fibonacci lattice)."""
    i = np.arange(n) + 0.5
    z, phi = 1 - 2 * i / n, np.pi * (1 + 5 ** 0.5) * i
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


DIRECTIONS = _directions()


def hull_gap(pa, pb) -> float:
    """A lower bound on the distance [mm] between two primitives: the best separating-axis gap
    g(m) = −(h_a(m) + h_b(−m)) over unit directions m (h the support functions), which for convex bodies
    equals their distance at the optimum: the best of 256 spread directions and the line between the boxes'
    centres, then a pattern search on the sphere. A wheel's bore and a sub-arc's curvature make their hulls
    larger, so it stays a lower bound."""
    gap = lambda m: -(pa.support(m) + pb.support(-m))
    d = pb.box.mean(axis=0) - pa.box.mean(axis=0)
    cands = np.vstack([_unit(d) if np.linalg.norm(d) > 1e-9 else DIRECTIONS[0], DIRECTIONS])
    gaps = gap(cands)
    m, g = cands[np.argmax(gaps)], float(np.max(gaps))
    step = 0.1
    while g <= 1.0 and step > 1e-5:
        t1 = _perp(m)
        t2 = np.cross(m, t1)
        trial = np.array([_unit(m + step * t) for t in (t1, -t1, t2, -t2, t1 + t2, t1 - t2, t2 - t1, -t1 - t2)])
        gaps = gap(trial)
        if gaps.max() > g:
            m, g = trial[np.argmax(gaps)], float(gaps.max())
        else:
            step /= 2
    return g


def screen(p: Plan, pieces: dict):
    """Refuse impossible geometry before anything is written: every two parts not built to touch must be
    apart (min distance > TOUCH_TOL). Primitive pairs whose convex hulls are more than 1 mm apart
    (`hull_gap`) pass at once; the others are measured on their OpenCascade solids. A wheel and its own
    axle are coaxial by construction (radial clearance BORE_CLEARANCE) and are left to `check_step`.
    One InputError line naming the file and the field."""
    from OCP.BRepExtrema import BRepExtrema_DistShapeShape

    touching = p.touching()
    for a, b in _candidate_pairs(p, 1.0):
        if frozenset((a.name, b.name)) in touching or f"axle_{a.name}" == b.name or f"axle_{b.name}" == a.name:
            continue
        for (pa, sa), (pb, sb) in itertools.product(zip(a.prims, pieces[a.name]), zip(b.prims, pieces[b.name])):
            if not _boxes_overlap(pa.box, pb.box, 1.0):
                continue
            if all(hull_gap(x, y) > 1.0 for x in pa.pieces for y in pb.pieces
                   if _boxes_overlap(x.box, y.box, 1.0)):
                continue
            d = BRepExtrema_DistShapeShape(sa.wrapped, sb.wrapped)
            if d.IsDone() and d.Value() <= TOUCH_TOL:
                first, second = (b, a) if a.kind == "sphere" or (a.kind == "roller" and b.kind != "roller") else (a, b)
                other = second.name if second.field == second.name else f"{second.name} ({second.field})"
                raise InputError(f"{p.layout.file}: {first.field}: part {first.name} runs into {other} at γ = "
                                 f"{np.degrees(p.gamma):g}°; expected every part clear of the others (only rollers "
                                 "touch the sphere)")


def assembly(p: Plan, shapes: dict):
    cq = _cq()
    assy = cq.Assembly(name=p.layout.name)
    for part in p.parts:
        assy.add(shapes[part.name], name=part.name, color=cq.Color(*part.colour))
    return assy


# --- files ----------------------------------------------------------------------------------------------

def _view_basis(direction):
    """(right, up, towards viewer) unit vectors of an orthographic view along `direction`, z drawn upwards."""
    d = _unit(direction)
    up = _unit(np.array([0.0, 0.0, 1.0]) - d[2] * d)
    return np.cross(up, d), up, d


def write_step(assy, path: Path):
    from cadquery.occ_impl.exporters.assembly import exportAssembly

    if not exportAssembly(assy, str(path)):
        raise RuntimeError(f"STEP writer failed for {path}")


def write_svg(p: Plan, shapes: dict, path: Path, view=VIEW):
    """Hidden-line drawing by cadquery's SVG exporter, viewed along VIEW with z upwards."""
    cq = _cq()
    from cadquery.occ_impl.exporters.svg import getSVG
    from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt

    # cadquery projects onto gp_Ax2(VIEW)'s own X/Y: turn the assembly about VIEW so that z comes out upwards
    ax = gp_Ax2(gp_Pnt(), gp_Dir(*view))
    y = np.array([ax.YDirection().X(), ax.YDirection().Y(), ax.YDirection().Z()])
    right, up, d = _view_basis(view)
    turn = np.degrees(np.arctan2(np.cross(up, y) @ d, up @ y))
    compound = cq.Compound.makeCompound([shapes[n] for n in p.names()]).rotate((0, 0, 0), tuple(d), turn)
    svg = getSVG(compound, {"width": 900, "height": 900, "marginLeft": 30, "marginTop": 30, "showAxes": False,
                            "projectionDir": tuple(view), "showHidden": False, "strokeWidth": -1})
    path.write_text(svg)


def view_mesh(p: Plan, shapes: dict, view=VIEW):
    """The front-facing triangles of every part in view coordinates along VIEW (z upwards), for `rasterise`:
    (triangles (T, 3, [right, up, towards viewer]) [mm], part index (T,), Lambert shade (T,))."""
    right, up, d = _view_basis(view)
    light = _unit(d + 0.6 * up + 0.3 * right)
    tris, ids, shades = [], [], []
    for i, part in enumerate(p.parts):
        verts, idx = shapes[part.name].tessellate(0.5, 0.4)             # [mm], [rad]
        verts, idx = np.array([v.toTuple() for v in verts]), np.array(idx)
        tri = verts[idx]
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])   # area-weighted, outward
        # smooth shading: average the normals at each vertex (cadquery does not share vertices between
        # faces, so edges between faces stay sharp)
        vn = np.zeros_like(verts)
        for k in range(3):
            np.add.at(vn, idx[:, k], normal)
        smooth = (vn / (np.linalg.norm(vn, axis=1, keepdims=True) + 1e-12))[idx].mean(axis=1)
        smooth /= np.linalg.norm(smooth, axis=1, keepdims=True) + 1e-12
        facing = normal @ d > 0                                          # back faces are hidden
        tris.append(tri[facing] @ np.array([right, up, d]).T)
        shades.append(0.35 + 0.65 * np.clip(smooth[facing] @ light, 0, 1))
        ids.append(np.full(int(facing.sum()), i))
    return np.concatenate(tris).astype(np.float32), np.concatenate(ids), np.concatenate(shades).astype(np.float32)


def rasterise(tri, ids, shade, colours, pixels: int = 800):
    """Flat-shaded orthographic image by z-buffer (numpy only): every triangle marks the pixel centres
    inside it with its depth, each pixel keeps the nearest; dark outlines where the part under a pixel
    changes. colours: RGB per part index. Returns a (pixels, pixels, 3) RGB array, white background."""
    tri = np.array(tri, float)
    xy = tri[..., :2].reshape(-1, 2)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    tri[..., :2] = (tri[..., :2] - (lo + hi) / 2) * (0.94 * pixels / max(hi - lo)) + pixels / 2
    tri[..., 1] = pixels - tri[..., 1]                                  # image rows grow downwards
    # candidate pixels: each triangle's bounding box of pixel centres, flattened
    start = np.floor(tri[:, :, :2].min(axis=1) - 0.5).astype(int) + 1
    size = np.maximum(np.floor(tri[:, :, :2].max(axis=1) - 0.5).astype(int) - start + 1, 0)
    count = size[:, 0] * size[:, 1]
    t = np.repeat(np.arange(len(tri)), count)
    local = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    cx = start[t, 0] + local % size[t, 0] + 0.5
    cy = start[t, 1] + local // size[t, 0] + 0.5
    (x0, y0, z0), (x1, y1, z1), (x2, y2, z2) = (tri[t, n].T for n in range(3))
    det = (y1 - y2) * (x0 - x2) + (x2 - x1) * (y0 - y2)
    det = np.where(np.abs(det) < 1e-12, 1e-12, det)
    w0 = ((y1 - y2) * (cx - x2) + (x2 - x1) * (cy - y2)) / det
    w1 = ((y2 - y0) * (cx - x2) + (x0 - x2) * (cy - y2)) / det
    w2 = 1 - w0 - w1
    inside = (w0 >= 0) & (w1 >= 0) & (w2 >= 0) & (cx > 0) & (cy > 0) & (cx < pixels) & (cy < pixels)
    depth = (w0 * z0 + w1 * z1 + w2 * z2)[inside]
    pix = cy[inside].astype(int) * pixels + cx[inside].astype(int)
    which = t[inside]
    o = np.lexsort((-depth, pix))                                       # per pixel, nearest first
    first = o[np.r_[True, pix[o][1:] != pix[o][:-1]]]
    part = np.full(pixels * pixels, -1)
    part[pix[first]] = ids[which[first]]
    image = np.ones((pixels * pixels, 3))
    image[pix[first]] = np.asarray(colours)[ids[which[first]]] * shade[which[first]][:, None]
    part, image = part.reshape(pixels, pixels), image.reshape(pixels, pixels, 3)
    edge = np.zeros_like(part, dtype=bool)
    edge[1:, :] |= part[1:, :] != part[:-1, :]
    edge[:, 1:] |= part[:, 1:] != part[:, :-1]
    image[edge] *= 0.25
    return image


def picture_caption(p: Plan) -> str:
    return (f"{p.layout.name}: γ = {np.degrees(p.gamma):g}°, φ = {np.degrees(p.phi):.2f}°, {len(p.parts)} parts "
            f"(view along {VIEW}, z up)")


# --- checks of the written STEP file -----------------------------------------------------------------------

def read_step(path: Path) -> dict:
    """{part name: (shape placed in N [mm], colour RGB or None)} from a STEP assembly (XCAF reader)."""
    cq = _cq()
    assy = cq.Assembly.importStep(str(path))
    out = {}
    for child in assy.children:
        shape = child.obj.moved(child.loc) if child.obj is not None else None
        out[child.name] = (shape, None if child.color is None else child.color.toTuple()[:3])
    return out


def _common_volume(a, b) -> float:
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Common

    op = BRepAlgoAPI_Common(a.wrapped, b.wrapped)
    if not op.IsDone():
        return float("inf")
    return _cq().Shape.cast(op.Shape()).Volume()


def _bbox(shape) -> np.ndarray:
    bb = shape.BoundingBox()          # BRepBndLib::AddOptimal: exact for these surfaces
    return np.array([[bb.xmin, bb.ymin, bb.zmin], [bb.xmax, bb.ymax, bb.zmax]])


def check_step(path: Path, p: Plan) -> list[dict]:
    """Re-read the STEP file and check it against the layout's plan. Returns [{check, ok, detail}]:

    * names and count: the parts, in order, are the plan's (sphere, rollers, axles, forks, couplings, frame);
    * one valid solid per part (BRepCheck_Analyzer) and each part in its planned colour;
    * every roller touches the sphere at R·n: min distance < TOUCH_TOL, nearest point within CONTACT_TOL of
      R·n (n the model's contact normal at φ), intersection volume < VOLUME_TOL;
    * no interference: every two parts whose boxes (from the file) come within 1 mm intersect by less than
      VOLUME_TOL (wheels and their own axles included: the bore's clearance is real);
    * attached parts touch: each fork touches its axles, each coupling its two axles (distance < TOUCH_TOL);
    * bounding box: the file's equals the one computed from the layout's geometry within BBOX_TOL."""
    from OCP.BRepExtrema import BRepExtrema_DistShapeShape

    rows = []

    def row(check, ok, detail):
        rows.append({"check": check, "ok": bool(ok), "detail": detail})

    parts = read_step(path)
    expected, got = p.names(), list(parts)
    row("names and count", got == expected, f"{len(got)} parts" + ("" if got == expected else
        f"; expected {len(expected)}: missing {sorted(set(expected) - set(got))}, "
        f"unexpected {sorted(set(got) - set(expected))}"))
    shapes = {n: s for n, (s, _) in parts.items() if s is not None}
    bad = [n for n in got if n not in shapes or len(shapes[n].Solids()) != 1 or not shapes[n].Solids()[0].isValid()]
    row("one valid solid per part", not bad, "all valid" if not bad else f"invalid or not one solid: {bad}")
    colour = {part.name: part.colour for part in p.parts}
    off = [n for n, (_, c) in parts.items() if c is None or n not in colour or np.max(np.abs(np.subtract(c, colour[n]))) > 1e-3]
    row("colours", not off, "as planned" if not off else f"wrong or missing: {off}")
    if got != expected or bad:
        return rows

    R = _mm(p.layout.sphere_radius)
    failed, worst = [], (0.0, 0.0, 0.0)
    for part in p.parts:
        if part.kind != "roller":
            continue
        d = BRepExtrema_DistShapeShape(shapes[part.name].wrapped, shapes["sphere"].wrapped)
        q = d.PointOnShape1(1)
        off = float(np.linalg.norm(np.array([q.X(), q.Y(), q.Z()]) - R * part.prims[0].normal))
        vol = _common_volume(shapes[part.name], shapes["sphere"])
        worst = tuple(max(w, x) for w, x in zip(worst, (d.Value(), off, vol)))
        if not (d.Value() < TOUCH_TOL and off < CONTACT_TOL and vol < VOLUME_TOL):
            failed.append(f"{part.name} (distance {d.Value():.3g} mm, {off:.3g} mm from R·n, overlap {vol:.3g} mm³)")
    row("rollers touch the sphere at R·n", not failed, f"largest distance {worst[0]:.1e} mm, offset from R·n "
        f"{worst[1]:.1e} mm, overlap {worst[2]:.1e} mm³" + (f"; failed: {failed}" if failed else ""))

    boxes = {n: _bbox(s) for n, s in shapes.items()}
    kind = {part.name: part.kind for part in p.parts}
    pairs, largest = 0, (0.0, "")
    for a, b in itertools.combinations(got, 2):
        if {kind[a], kind[b]} == {"roller", "sphere"} or not _boxes_overlap(boxes[a], boxes[b], 1.0):
            continue                  # the rollers' contact with the sphere is checked above
        pairs += 1
        vol = _common_volume(shapes[a], shapes[b])
        if vol >= largest[0]:
            largest = (vol, f"{a}/{b}")
    row("no interference", largest[0] < VOLUME_TOL, f"{pairs} pairs of parts near each other; largest "
        f"intersection {largest[0]:.1e} mm³" + (f" ({largest[1]})" if largest[0] > 0 else ""))
    joints = [tuple(t) for t in p.touching() if "sphere" not in t]
    loose = [f"{a}/{b}" for a, b in joints if shapes[a].distance(shapes[b]) >= TOUCH_TOL]
    row("attached parts touch", not loose, f"{len(joints)} fork–axle and coupling–axle joints"
        + (f"; apart: {loose}" if loose else ""))

    exp = p.bbox()
    dev = float(np.max(np.abs(_bbox(_cq().Compound.makeCompound(list(shapes.values()))) - exp)))
    size = exp[1] - exp[0]
    row("bounding box", dev < BBOX_TOL, f"{size[0]:.1f} × {size[1]:.1f} × {size[2]:.1f} mm; largest deviation "
        f"from the layout's {dev:.1e} mm")
    return rows


# --- the public entry point --------------------------------------------------------------------------------

def export_variant(layout_or_path, out_dir="cad_out", gamma_deg: float = 45.0, check: bool = False) -> dict:
    """Export a variant's assembly at commanded γ [deg] as `<out_dir>/<name>.step` (+ .svg, .png).

    `layout_or_path`: a numeric `Layout` or a variant file. Impossible geometry raises InputError before
    anything is written; the three files appear together or not at all. The PNG is drawn in a second
    process (plots.Background, matplotlib imported there while cadquery is imported here). Returns
    {step, svg, png (paths), parts (names), gamma_deg, phi_deg, seconds (export time), and with `check`:
    checks ([{check, ok, detail}], see `check_step`), check_seconds}."""
    from cvtdesign.io import plots

    t0 = time.perf_counter()
    painter = plots.Background()
    try:
        if isinstance(layout_or_path, Layout):
            from cvtdesign.core.checks import check_layout

            layout = layout_or_path
            check_layout(layout)
        else:
            layout = load_variant(layout_or_path)
        p = plan(layout, gamma_deg)
        shapes, pieces = build(p)
        screen(p, pieces)
        out = make_folder(out_dir, kind="CAD output folder")
        paths = [out / f"{layout.name}.{ext}" for ext in ("step", "svg", "png")]
        mesh = view_mesh(p, shapes)
        with staged(paths, kind="CAD file") as tmps:     # the three files appear together or not at all
            # hand the mesh over from a thread: the pipe blocks until the plotting process reads it
            sender = threading.Thread(target=painter.draw, args=("cad_picture", *mesh, [part.colour for part in p.parts],
                                                                  picture_caption(p), tmps[2]))
            sender.start()
            write_step(assembly(p, shapes), tmps[0])
            write_svg(p, shapes, tmps[1])
            sender.join()
            error = painter.wait()
            if error:
                raise RuntimeError(f"PNG rendering failed: {error}")
    finally:
        painter.close()
    result = {"step": str(paths[0]), "svg": str(paths[1]), "png": str(paths[2]), "parts": p.names(),
              "gamma_deg": float(gamma_deg), "phi_deg": float(np.degrees(p.phi)),
              "seconds": time.perf_counter() - t0}
    if check:
        t1 = time.perf_counter()
        result["checks"] = check_step(paths[0], p)
        result["check_seconds"] = time.perf_counter() - t1
    return result
