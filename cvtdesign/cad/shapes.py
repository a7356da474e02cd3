"""Solid primitives of the CAD parts, described in numpy (mm): `Ball`, `Rod`, `Block`, `Crowned`, `ArcTube`,
`Pipe`, and `rounded_path` (a bent tube's segments along a polyline).

A primitive has an exact support function h(m) = max over the body of x·m [mm] for unit directions m, from
which its bounding box, the fork heights, the frame clearance and the fast clearance screen
(`step.hull_gap`) follow from the layout alone, without OpenCascade. `solid(cq)` builds its OpenCascade
solid with the cadquery module it is handed (see `kernel`); nothing here imports cadquery.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np


def unit(v) -> np.ndarray:
    """v scaled to length 1."""
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def vec3(v) -> np.ndarray:
    """A numeric 3-vector (numpy array, list or CasADi DM) as a flat numpy array."""
    return np.asarray(v.full() if hasattr(v, "full") else v, float).ravel()


def perp(v) -> np.ndarray:
    """A unit vector perpendicular to unit v."""
    e = np.eye(3)[np.argmin(np.abs(v))]
    return unit(np.cross(v, e))


def boxes_overlap(a, b, margin: float) -> bool:
    """Whether boxes a and b ([[min], [max]] [mm]) come within `margin` [mm] of each other."""
    return bool(np.all(a[0] - margin <= b[1]) and np.all(b[0] - margin <= a[1]))


def _root(x):
    return np.sqrt(np.clip(x, 0.0, None))


class Primitive:
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


@dataclass(frozen=True)
class Ball(Primitive):
    centre: np.ndarray
    radius: float

    def support(self, m):
        return m @ self.centre + self.radius

    def reach(self):
        return float(np.linalg.norm(self.centre) + self.radius)

    def solid(self, cq):
        return cq.Solid.makeSphere(self.radius, cq.Vector(*self.centre), angleDegrees1=-90, angleDegrees2=90)


@dataclass(frozen=True)
class Rod(Primitive):
    """Flat-ended cylinder from p0 to p1."""
    p0: np.ndarray
    p1: np.ndarray
    radius: float

    def support(self, m):
        a = unit(self.p1 - self.p0)
        return np.maximum(m @ self.p0, m @ self.p1) + self.radius * _root(1 - (m @ a) ** 2)

    def reach(self):
        return float(max(np.linalg.norm(self.p0), np.linalg.norm(self.p1)) + self.radius)

    def solid(self, cq):
        d = self.p1 - self.p0
        return cq.Solid.makeCylinder(self.radius, float(np.linalg.norm(d)), cq.Vector(*self.p0), cq.Vector(*unit(d)))


@dataclass(frozen=True)
class Block(Primitive):
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
class Crowned(Primitive):
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
class ArcTube(Primitive):
    """Tube of radius `radius` round a circular arc: centre o, unit axis m, from `start` by `angle` [rad]
    (right-handed about m)."""
    centre: np.ndarray
    axis: np.ndarray
    start: np.ndarray
    angle: float
    radius: float

    @functools.cached_property
    def frame(self):
        """(radius of the arc [mm], unit vector from the centre to the start, the arc's tangent there)."""
        e1 = self.start - self.centre
        rc = float(np.linalg.norm(e1))
        e1 = e1 / rc
        return rc, e1, np.cross(self.axis, e1)

    def point(self, th):
        """The point of the arc's centre line at angle th [rad] from the start."""
        rc, e1, e2 = self.frame
        return self.centre + rc * (np.cos(th) * e1 + np.sin(th) * e2)

    def support(self, m):
        # c·m + rc·C cos δ + ρ √(1 − C² sin² δ) decreases in |δ| = |θ − θ0| (rc > ρ): take the arc's θ nearest θ0
        rc, e1, e2 = self.frame
        A, B = m @ e1, m @ e2
        C, th0 = np.hypot(A, B), np.arctan2(B, A) % (2 * np.pi)
        th = np.where(th0 <= self.angle, th0, np.where(th0 - self.angle < 2 * np.pi - th0, self.angle, 0.0))
        d = th - th0
        return m @ self.centre + rc * C * np.cos(d) + self.radius * _root(1 - (C * np.sin(d)) ** 2)

    def reach(self):
        rc, _, _ = self.frame
        return float(np.linalg.norm(self.centre) + rc + self.radius)

    @functools.cached_property
    def pieces(self):
        n = int(np.ceil(self.angle / np.radians(10)))
        return [ArcTube(self.centre, self.axis, self.point(i * self.angle / n), self.angle / n, self.radius)
                for i in range(n)]

    def solid(self, cq):
        _, _, e2 = self.frame
        circle = cq.Wire.makeCircle(self.radius, cq.Vector(*self.start), cq.Vector(*e2))
        face = cq.Face.makeFromWires(circle)
        return cq.Solid.revolve(face, float(np.degrees(self.angle)), cq.Vector(*self.centre),
                                cq.Vector(*(self.centre + self.axis)))


@dataclass(frozen=True)
class Pipe(Primitive):
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
                edges.append(cq.Edge.makeThreePointArc(*(cq.Vector(*seg.point(th)) for th in (0.0, seg.angle / 2, seg.angle))))
        first = self.segments[0]
        start, tangent = (first.p0, unit(first.p1 - first.p0)) if isinstance(first, Rod) else (first.start, first.frame[2])
        circle = cq.Wire.makeCircle(first.radius, cq.Vector(*start), cq.Vector(*tangent))
        return cq.Solid.sweep(circle, [], cq.Wire.assembleEdges(edges), makeSolid=True)


def rounded_path(points, radius, bend):
    """Segments of a tube of `radius` along the polyline `points` [mm] with corner i rounded by an arc of
    radius bend[i] (or `bend` at every corner; smaller where the segments are short, never below
    1.5 × radius)."""
    pts = [np.asarray(q, float) for i, q in enumerate(points) if i == 0 or np.linalg.norm(q - points[i - 1]) > 1e-9]
    dirs = [unit(b - a) for a, b in zip(pts, pts[1:])]
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
            inward = unit(dirs[i + 1] - dirs[i])                     # towards the bend's centre
            centre = a + bends[i] * unit(inward - (inward @ dirs[i]) * dirs[i])
            axis = unit(np.cross(a - centre, dirs[i]))
            segments.append(ArcTube(centre, axis, a, turns[i], radius))
            here = b
        elif i == len(turns):
            segments.append(Rod(here, end, radius))
    return tuple(segments)
