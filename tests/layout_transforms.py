"""Transforms of a variant *dict* (as `yaml.safe_load` gives it) that describe the same machine another way.

A test helper, not part of the package. Every transform returns a new dict and leaves its argument alone:

* `explicit(data)`: every vector field (each roller's `contact` and `axle`, each fork's `axis`, `frame.side`)
  and every follower's `ratio` written out as numbers, from the resolved layout, so that the others can act
  on plain lists whatever form the file used (frame names, lists, {polar, azimuth} over `parameters`);
* `rotate(data, Q)`: the layout turned by a rotation matrix Q (det +1);
* `mirror(data, P)`: its mirror image in a reflection P (det −1); each fork's `sign` is negated, because a
  reflection reverses the sense of a rotation: P·R(k, θ)·Pᵀ = R(P k, −θ);
* `flip_axle(data, roller, followers=...)`: one roller's positive spin axis declared the other way;
* `flip_fork(data, i)`: fork i's axis and sign both negated (the same linkage written the other way);
* `relabel_shafts(data)`: shafts 1 and 2 swapped on every drive and follower roller;
* `set_envelope`, `set_radius` and `consistent_ratio` for the property tests.

`layout_of(data)` writes a dict to a temporary file and loads it with `cvtdesign.io.variant.load_variant`.
"""
from __future__ import annotations

import copy
import tempfile
from pathlib import Path

import numpy as np
import yaml

from cvtdesign.core.geometry import named_vector, pose, spherical
from cvtdesign.io.units import to_si
from cvtdesign.io.variant import load_variant

ROOT = Path(__file__).resolve().parents[1]
VARIANTS = ROOT / "variants"


# ---------------------------------------------------------------------------------------------- reading

def read(name_or_path) -> dict:
    """A shipped variant by name ('existing', 'box', 'unequal') or any variant file, as a plain dict."""
    p = Path(name_or_path)
    if p.suffix != ".yaml":
        p = VARIANTS / f"{name_or_path}.yaml"
    return yaml.safe_load(p.read_text())


def dump(data: dict, path) -> Path:
    """Write a variant dict as YAML. PyYAML writes floats with repr, so numbers round-trip exactly."""
    path = Path(path)
    path.write_text(yaml.safe_dump(data, sort_keys=False, allow_unicode=True))
    return path


def layout_of(data: dict, check: bool = False, overrides: dict | None = None):
    """Write `data` to a temporary file and load it (`load_variant(..., check=check)`)."""
    with tempfile.TemporaryDirectory(prefix="cvt_variant_") as d:
        path = dump(data, Path(d) / f"{data.get('name', 'variant')}.yaml")
        return load_variant(path, overrides=overrides, check=check)


def as_array(v) -> np.ndarray:
    """A numeric 3-vector (numpy array, list or CasADi DM) as a flat float array."""
    if hasattr(v, "full"):
        v = v.full()
    return np.asarray(v, dtype=float).ravel()


def _floats(v) -> list[float]:
    return [float(x) for x in as_array(v)]


def _side_vector(spec, names) -> np.ndarray:
    """frame.side resolved like a vector field of the variant (it is not kept in the Layout)."""
    if isinstance(spec, str):
        v = named_vector(spec.strip())
        if v is None:
            raise ValueError(f"frame.side: not a frame vector name: {spec!r}")
        return v
    if isinstance(spec, dict) or hasattr(spec, "polar"):
        get = spec.get if isinstance(spec, dict) else lambda k: getattr(spec, k)
        return as_array(spherical(to_si(get("polar"), "angle", "frame.side.polar", names),
                                  to_si(get("azimuth"), "angle", "frame.side.azimuth", names)))
    v = np.asarray(spec, float)
    return v / np.linalg.norm(v)


# ---------------------------------------------------------------------------------------------- transforms

def explicit(data: dict) -> dict:
    """The same variant with every vector field and every follower ratio written as numbers (full precision):
    contact = the roller's unit normal at φ = 0, axle = its unit spin axis at φ = 0, fork axis = the unit
    axis its rollers turn about, frame.side = the unit side vector. Everything else is kept as written."""
    layout = layout_of(data, check=False)
    out = copy.deepcopy(data)
    by_name = {r.name: r for r in layout.rollers}
    for name, spec in out["rollers"].items():
        r = by_name[name]
        n, a = pose(r, 0.0)
        spec["contact"], spec["axle"] = _floats(n), _floats(a)
        if spec.get("role") == "follower":
            spec["ratio"] = float(r.ratio)
    for fork in out["steering"]["forks"]:
        fork["axis"] = _floats(by_name[fork["rollers"][0]].fork_axis)
        fork["sign"] = int(fork.get("sign", 1))
    if out.get("frame") and "side" in out["frame"]:
        out["frame"]["side"] = _floats(_side_vector(out["frame"]["side"], layout.parameters))
    return out


def _is_explicit(data: dict) -> bool:
    def plain(v):
        return isinstance(v, list) and len(v) == 3 and all(isinstance(x, (int, float)) for x in v)
    return (all(plain(s["contact"]) and plain(s["axle"]) for s in data["rollers"].values())
            and all(plain(f["axis"]) for f in data["steering"]["forks"])
            and (not data.get("frame") or "side" not in data["frame"] or plain(data["frame"]["side"]))
            and all(isinstance(s.get("ratio", 1), (int, float))
                    for s in data["rollers"].values() if s.get("role") == "follower"))


def _map_vectors(data: dict, M: np.ndarray) -> dict:
    out = explicit(data) if not _is_explicit(data) else copy.deepcopy(data)
    for spec in out["rollers"].values():
        spec["contact"] = _floats(M @ np.asarray(spec["contact"], float))
        spec["axle"] = _floats(M @ np.asarray(spec["axle"], float))
    for fork in out["steering"]["forks"]:
        fork["axis"] = _floats(M @ np.asarray(fork["axis"], float))
    if out.get("frame") and "side" in out["frame"]:
        out["frame"]["side"] = _floats(M @ np.asarray(out["frame"]["side"], float))
    return out


def _orthogonal(M, det: int, what: str) -> np.ndarray:
    M = np.asarray(M, float)
    if M.shape != (3, 3) or not np.allclose(M @ M.T, np.eye(3), atol=1e-12):
        raise ValueError(f"{what}: expected an orthogonal 3×3 matrix")
    if not np.isclose(np.linalg.det(M), det, atol=1e-9):
        raise ValueError(f"{what}: expected det {det:+d}, got {np.linalg.det(M):+.3g}")
    return M


def rotate(data: dict, Q) -> dict:
    """Every contact, axle, fork axis (and frame side) multiplied by the rotation matrix Q (det +1)."""
    return _map_vectors(data, _orthogonal(Q, +1, "rotate"))


def mirror(data: dict, P) -> dict:
    """The mirror image in the reflection P (det −1): every vector multiplied by P and every fork's sign
    negated, since P·R(k, θ)·Pᵀ = R(P k, −θ): then pose_mirrored(r, φ) = P·pose(r, φ) at every φ."""
    out = _map_vectors(data, _orthogonal(P, -1, "mirror"))
    for fork in out["steering"]["forks"]:
        fork["sign"] = -int(fork["sign"])
    return out


def _neg(v):
    return [-float(x) for x in v]


FOLLOWER_MODES = ("ratio", "axle", "none")


def flip_axle(data: dict, roller: str, followers: str = "ratio") -> dict:
    """Declare `roller`'s positive spin axis the other way (axle → −axle), keeping the machine the same:

    * steering roller: only its axle (its idler speed is counted the other way);
    * follower: its axle and its ratio (roller speed / shaft speed) are negated together;
    * drive roller: its shaft's speed (and torque) is counted the other way, so every other roller on that
      shaft must follow: other drive rollers (ratio fixed at 1) flip their axles; followers get their
      `ratio` negated (followers='ratio') or their axles flipped with it (followers='axle').
      followers='none' leaves them alone: the followers then fight the shaft (for negative tests).
    """
    if followers not in FOLLOWER_MODES:
        raise ValueError(f"followers must be one of {FOLLOWER_MODES}, not {followers!r}")
    out = explicit(data) if not _is_explicit(data) else copy.deepcopy(data)
    rs = out["rollers"]
    spec = rs[roller]
    spec["axle"] = _neg(spec["axle"])
    role = spec["role"]
    if role == "follower":
        spec["ratio"] = -float(spec["ratio"])
    elif role == "drive" and followers != "none":
        for name, other in rs.items():
            if name == roller or other.get("shaft") != spec["shaft"]:
                continue
            if other["role"] == "drive" or followers == "axle":
                other["axle"] = _neg(other["axle"])
            else:
                other["ratio"] = -float(other["ratio"])
    return out


def flip_fork(data: dict, i: int) -> dict:
    """Fork i written the other way: axis → −axis and sign → −sign (R(−k, −θ) = R(k, θ))."""
    out = explicit(data) if not _is_explicit(data) else copy.deepcopy(data)
    fork = out["steering"]["forks"][i]
    fork["axis"] = _neg(fork["axis"])
    fork["sign"] = -int(fork["sign"])
    return out


def relabel_shafts(data: dict) -> dict:
    """Shafts 1 and 2 swapped on every drive and follower roller (no vector changes). The motor is then the
    old brake shaft: the old point (γ, τ⊥) is the relabelled (90° − γ, ∓τ⊥) (see test_invariance)."""
    out = copy.deepcopy(data)
    for spec in out["rollers"].values():
        if spec.get("role") in ("drive", "follower"):
            spec["shaft"] = 3 - int(spec["shaft"])
    return out


# ---------------------------------------------------------------------------------------------- edits

def set_envelope(data: dict, gamma_deg=(-60, 60, 30), load_nm=(-1, 1, 1), motor_speed=None) -> dict:
    """The envelope as (start, stop, step) in deg and N·m (motor speed kept unless given, in rad/s)."""
    out = copy.deepcopy(data)
    env = dict(out.get("envelope") or {})
    env["gamma"] = {k: f"{v!r} deg" for k, v in zip(("start", "stop", "step"), map(float, gamma_deg))}
    env["load"] = {k: f"{v!r} N*m" for k, v in zip(("start", "stop", "step"), map(float, load_nm))}
    if motor_speed is not None:
        env["motor_speed"] = f"{float(motor_speed)!r} rad/s"
    out["envelope"] = env
    return out


def consistent_ratio(data: dict, follower: str) -> float:
    """The follower ratio (roller speed / shaft speed) that lets `follower` roll without slip with its shaft's
    first drive roller p: r_f ρ_f ω_s = −R Ω·a_f and r_p ω_s = −R Ω·a_p for every motion, so a_f = ±a_p and
    ρ_f = (r_p / r_f)(a_f·a_p)."""
    layout = layout_of(data, check=False)
    by = {r.name: r for r in layout.rollers}
    f = by[follower]
    p = next(r for r in layout.rollers if r.role == "drive" and r.shaft == f.shaft)
    af, ap = pose(f, 0.0)[1], pose(p, 0.0)[1]
    dot = float(af @ ap)
    if not np.isclose(abs(dot), 1.0, atol=1e-9):
        raise ValueError(f"{follower}: axle not parallel to its shaft's drive roller {p.name} (a_f·a_p = {dot:.3g})")
    return float(float(p.radius) / float(f.radius) * np.sign(dot))


def set_radius(data: dict, roller: str, radius_m: float, keep_followers: bool = True) -> dict:
    """Set a roller's radius [m]; with `keep_followers`, every follower on a changed drive roller's shaft (or
    the changed follower itself) gets the ratio that keeps the layout kinematically consistent."""
    out = copy.deepcopy(data)
    out["rollers"][roller]["radius"] = float(radius_m)
    if not keep_followers:
        return out
    spec = out["rollers"][roller]
    if spec["role"] == "follower":
        targets = [roller]
    elif spec["role"] == "drive":
        targets = [n for n, s in out["rollers"].items() if s["role"] == "follower" and s["shaft"] == spec["shaft"]]
    else:
        targets = []
    for name in targets:
        out["rollers"][name]["ratio"] = consistent_ratio(out, name)
    return out


# ---------------------------------------------------------------------------------------------- matrices

def quaternion_matrix(q) -> np.ndarray:
    """Rotation matrix of the quaternion (w, x, y, z), normalised first."""
    w, x, y, z = np.asarray(q, float) / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def axis_angle_matrix(axis, angle) -> np.ndarray:
    """Rotation by `angle` [rad] about the unit vector `axis` (right-handed)."""
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def householder(v) -> np.ndarray:
    """Reflection in the plane through the origin perpendicular to v (det −1)."""
    v = np.asarray(v, float) / np.linalg.norm(v)
    return np.eye(3) - 2 * np.outer(v, v)
