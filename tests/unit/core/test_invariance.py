"""The same machine written another way gives the same figures.

A layout's kinematics (γ, α, the ideal law, τ⊥) must come from its own shaft axes, so turning the whole
layout (a rotation), taking its mirror image, declaring an axle's or a fork's positive sense the other way,
or swapping the names of shafts 1 and 2 may change only sign conventions, never the physics. The transforms
act on variant dicts (tests/layout_transforms.py); the first section checks them on their own (geometry
only), the second compiles the model.

Maps of an operating point (γ, τ⊥) of the original to the transformed layout (the motor, shaft 1, always
turns forwards at the envelope's speed), with s_k = −1 when shaft k's sense is reversed, else +1:

* rotation: (γ, τ⊥) → (γ, τ⊥), the same state turned: α, its parts, N, F, utilisation all equal;
* reversing shaft k (flip_axle of its drive roller, followers kept consistent): (γ, τ⊥, α) →
  (s1 s2 γ, s1 s2 τ⊥, s1 s2 α). Reversing shaft 1 turns the motor the other way, i.e. the model then
  solves the *reversed* motion (Ω, ω, F → −Ω, −ω, −F), whose normal forces differ (the net tangential
  force on the sphere reverses), so N is compared pointwise only when shaft 1 keeps its sense;
* mirror image P (vectors × P, fork signs negated): (γ, τ⊥, α) → (γ, τ⊥, α), the state being the mirror
  image of the reversed motion (Ω → PΩ, F → −PF), so again α pointwise, N only through the figures;
* flipping a fork (axis, sign → −axis, −sign): nothing changes at all;
* relabelling the shafts (1 ↔ 2): for 0 < γ < 90° the same state is the relabelled point (90° − γ, −τ⊥)
  with α → −α. For −90° < γ < 0 the old brake shaft turns backwards, so the relabelled model (new motor
  forwards) solves the reversed motion: the point is (90° − γ, +τ⊥) ≡ (−90° − γ, −τ⊥), α → −α. (τ⊥ =
  −τ1 sin γ + τ2 cos γ changes sign with γ → γ + 180°, the same axis line.) The relabelled γ range for
  Kim's −80°..80° is 10°..170°; at 90° the new motor shaft would stand still, and an envelope with γ = 90°
  is refused.

Envelopes are small (γ −60°..60° step 30°, τ⊥ −1..1 N·m step 1) and symmetric, so every map above takes
the grid onto itself and the figures of `evaluate.metrics` must agree to 1e-6 relative. The shipped layouts
are symmetric under the mirror z → −z (with S1 ↔ S2, N ↔ S), which is why the reversed motion gives the
same maxima of utilisation and Hertz pressure over the envelope.
"""
from __future__ import annotations

import copy
import functools
import math

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, Phase, example, given, settings
from hypothesis import strategies as st

import layout_transforms as lt

from cvtdesign.core import metrics as ev
from cvtdesign.core.geometry import pose, rigid_constraints
from cvtdesign.core.model import compile_model

SHIPPED = ("existing_kim", "box_kim", "unequal_kim")
# the same layouts under contact law kalker (every direction compliant, spin through C23): the model tests
# run on them too, which checks the patch frame and the spin term's sign under rotation and mirroring
KALKER = ("existing+kalker", "box+kalker")
SMALL = dict(gamma_deg=(-60, 60, 30), load_nm=(-1, 1, 1))
FIGURES = ("max_abs_alpha_deg", "rms_alpha_deg", "max_abs_alpha_steering_deg", "max_abs_alpha_drive_deg",
           "ratio_error_pct_at_max_load", "min_efficiency", "max_traction_utilisation", "max_hertz_pressure_MPa",
           "max_steering_torque_Nm", "max_standstill_steering_torque_Nm")
ANGLES = ("alpha", "alpha_steering", "alpha_drive")
ANGLE_TOL = 1e-9    # [rad] pointwise α, α_steering, α_drive (found: < 1e-15)
# pointwise N, utilisation, p_max, speeds, torques, relative to the largest value of the envelope: the
# lateral forces that only the 1e-9 1/N compliance floor (core.contact.laws.EPS_RIGID) decides are solved to ~1e-8
# relative, and N and utilisation inherit ~1e-9 of it (found up to 1.5e-9 over 25 random rotations)
FORCE_TOL = 1e-8

# deterministic, no example database, no shrinking (a failing example is reported as found: shrinking
# would compile dozens of models); `too_slow`: a model compiles in ~0.3 s
_COMMON = dict(deadline=None, derandomize=True, database=None, phases=(Phase.explicit, Phase.generate),
               suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much], print_blob=False)
GEOMETRY = settings(max_examples=25, **_COMMON)     # transforms only, no model
MODEL = settings(max_examples=8, **_COMMON)         # each example compiles one model (~0.3 s)


# ---------------------------------------------------------------------------------------------- fixtures
# plain cached functions rather than pytest fixtures: hypothesis tests may not use function-scoped
# fixtures, and a conftest.py may come later

@functools.cache
def _base(name: str) -> dict:
    shipped, _, law = name.partition("+")
    data = lt.read(shipped)
    if law:
        data["contact"] = {"law": law}
    return lt.set_envelope(data, **SMALL)


def base(name: str) -> dict:
    """The shipped variant with the small envelope (a fresh copy)."""
    return copy.deepcopy(_base(name))


@functools.cache
def reference(name: str):
    """(model, envelope result, metrics) of the shipped variant with the small envelope."""
    model = compile_model(lt.layout_of(base(name), check=False))
    res = ev.envelope(model)
    return model, res, ev.metrics(model, res)


def solve(data: dict):
    model = compile_model(lt.layout_of(data, check=False))
    res = ev.envelope(model)
    return model, res, ev.metrics(model, res)


def roller_names(name: str) -> list[str]:
    return list(base(name)["rollers"])


# ---------------------------------------------------------------------------------------------- strategies

_unit_interval = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
quaternions = st.tuples(_unit_interval, _unit_interval, _unit_interval, _unit_interval).filter(
    lambda q: np.linalg.norm(q) > 0.2)
directions = st.tuples(_unit_interval, _unit_interval, _unit_interval).filter(lambda v: np.linalg.norm(v) > 0.2)
steering_angles = st.floats(-1.4, 1.4, allow_nan=False)


def reflection(q, v) -> np.ndarray:
    """An improper orthogonal matrix: a rotation after the Householder reflection in the plane ⊥ v."""
    return lt.quaternion_matrix(q) @ lt.householder(v)


# ---------------------------------------------------------------------------------------------- assertions

def assert_same_figures(got: dict, want: dict, rel=1e-6, what=""):
    bad = [f"{k}: {got[k]!r} vs {want[k]!r}" for k in FIGURES       # None (not modelled) only where both are
           if (got[k] is None) != (want[k] is None) or
           (got[k] is not None and not math.isclose(got[k], want[k], rel_tol=rel, abs_tol=1e-12))]
    assert got["not_converged"] == 0 and want["not_converged"] == 0, \
        f"{what}: points not converged: {got['not_converged']} (transformed), {want['not_converged']} (original)"
    assert not bad, f"{what}: figures differ (rel. tol. {rel:g}):\n  " + "\n  ".join(bad)


def assert_close(got, want, what, rtol=0.0, atol=0.0, scaled=0.0):
    """|got − want| ≤ atol + rtol·|want| + scaled·max|want| everywhere, and the same points converged."""
    got, want = np.asarray(got, float), np.asarray(want, float)
    assert np.array_equal(np.isfinite(got), np.isfinite(want)), f"{what}: converged points differ"
    if not np.isfinite(want).any():
        return
    diff = np.abs(got - want)
    tol = atol + rtol * np.abs(want) + scaled * np.nanmax(np.abs(want))
    assert np.nanmax(diff - tol) <= 0, (
        f"{what}: differs by up to {np.nanmax(diff):.3g} (largest |value| {np.nanmax(np.abs(want)):.3g}; "
        f"rtol {rtol:g}, atol {atol:g}, scaled {scaled:g})\n got  {np.array2string(got, precision=6)}\n "
        f"want {np.array2string(want, precision=6)}")


def gram(vectors) -> np.ndarray:
    V = np.array(vectors)
    return V @ V.T


# ==============================================================================================
# 1. the transforms on their own (geometry, no model)
# ==============================================================================================

@pytest.mark.parametrize("name", SHIPPED)
def test_explicit_round_trip(name, tmp_path):
    """explicit(): every vector written as 3 floats gives the same poses at every φ, and the file written
    from it reads back exactly (floats written with repr)."""
    data = base(name)
    e = lt.explicit(data)
    for spec in e["rollers"].values():
        assert all(isinstance(x, float) for x in spec["contact"] + spec["axle"])
    L0, L1 = lt.layout_of(data), lt.layout_of(e)
    for r0, r1 in zip(L0.rollers, L1.rollers):
        assert r0.name == r1.name and r0.fork_ratio == r1.fork_ratio
        for phi in (0.0, 0.3, -1.1):
            for v0, v1 in zip(pose(r0, phi), pose(r1, phi)):
                np.testing.assert_allclose(v1, v0, rtol=0, atol=1e-15)
    assert yaml.safe_load(lt.dump(e, tmp_path / "e.yaml").read_text()) == e


def test_explicit_frame_side():
    """frame.side, given by name, list or {polar, azimuth} over the parameters, becomes a unit list."""
    data = base("box_kim")
    for side, want in (("-z", [0, 0, -1]), ([0, 3, 4], [0, 0.6, 0.8]),
                       ({"polar": "= asin(d / (2*R))", "azimuth": "90 deg"}, [0, 30 / 63.5, np.sqrt(1 - (30 / 63.5) ** 2)])):
        data["frame"] = {"side": side, "distance": "200 mm"}
        np.testing.assert_allclose(lt.explicit(data)["frame"]["side"], want, atol=1e-15)
    data["frame"] = {"side": "-z", "distance": "200 mm"}
    Q = lt.axis_angle_matrix([1, 0, 0], np.pi / 2)
    np.testing.assert_allclose(lt.rotate(data, Q)["frame"]["side"], Q @ [0, 0, -1], atol=1e-15)


def same_dot_products(data: dict, changed: dict) -> tuple:
    """The two layouts, after checking that every dot product of their normals and axles (at φ = 0) agrees."""
    L0, L1 = lt.layout_of(data), lt.layout_of(changed)
    vs0 = [v for r in L0.rollers for v in pose(r, 0.0)]
    vs1 = [v for r in L1.rollers for v in pose(r, 0.0)]
    np.testing.assert_allclose(gram(vs1), gram(vs0), atol=1e-12)
    return L0, L1


@pytest.mark.slow
@pytest.mark.parametrize("name", SHIPPED)
@GEOMETRY
@given(q=quaternions, phi=steering_angles)
@example(q=(np.cos(np.pi / 8), 0.0, 0.0, np.sin(np.pi / 8)), phi=0.5)   # 45° about z: d1 → y, d2 → −x
def test_rotate(name, q, phi):
    """rotate(Q): dot products of all normals and axles kept; every pose at φ is Q·(the original's at φ)."""
    Q = lt.quaternion_matrix(q)
    data = base(name)
    rot = lt.rotate(data, Q)
    L0, L1 = same_dot_products(data, rot)
    for r0, r1 in zip(L0.rollers, L1.rollers):
        assert (r0.name, r0.role, r0.shaft, r0.fork_ratio) == (r1.name, r1.role, r1.shaft, r1.fork_ratio)
        for v0, v1 in zip(pose(r0, phi), pose(r1, phi)):
            np.testing.assert_allclose(v1, Q @ v0, atol=1e-12)
        if r0.fork_axis is not None:
            np.testing.assert_allclose(lt.as_array(r1.fork_axis), Q @ lt.as_array(r0.fork_axis), atol=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize("name", SHIPPED)
@GEOMETRY
@given(q=quaternions, v=directions, phi=steering_angles)
@example(q=(1.0, 0.0, 0.0, 0.0), v=(0.0, 0.0, 1.0), phi=0.5)   # z → −z, a symmetry of the shipped layouts
def test_mirror(name, q, v, phi):
    """mirror(P): dot products kept; with every fork's sign negated, poses at φ are P·(the original's at φ);
    without the negation the steered rollers would turn the wrong way."""
    P = reflection(q, v)
    data = base(name)
    mir = lt.mirror(data, P)
    L0, L1 = same_dot_products(data, mir)
    for r0, r1 in zip(L0.rollers, L1.rollers):
        assert r1.fork_ratio == -r0.fork_ratio
        for v0, v1 in zip(pose(r0, phi), pose(r1, phi)):
            np.testing.assert_allclose(v1, P @ v0, atol=1e-12)
    # the same vectors with the original signs: a steered axle turns the other way (Kim's forks turn about
    # the contact normal, the box's about z: both move the axle with φ)
    unsigned = lt.mirror(data, P)
    for fork, orig in zip(unsigned["steering"]["forks"], lt.explicit(data)["steering"]["forks"]):
        fork["sign"] = orig["sign"]
    L2 = lt.layout_of(unsigned)
    worst = max(np.max(np.abs(pose(r2, phi)[1] - P @ pose(r0, phi)[1]))
                for r0, r2 in zip(L0.rollers, L2.rollers) if r0.fork_axis is not None)
    if abs(np.sin(phi)) > 1e-6:
        assert worst > 0.5 * abs(np.sin(phi)), "a mirrored fork with the original sign should turn the other way"


def _rigid_motion(layout, phi=0.0) -> np.ndarray:
    """The rigid layout's one free motion [Ω (3), ω1, ω2, idler speeds], scaled so that |Ω| = 1 and Ω's
    largest component is positive; raises if the rollers leave not exactly one motion."""
    A = rigid_constraints(layout, phi)
    _, sv, vt = np.linalg.svd(A)
    null = int(np.sum(sv < 1e-9 * sv[0])) + max(0, A.shape[1] - A.shape[0])
    if null != 1:
        raise AssertionError(f"{null} rigid motions (expected exactly 1)")
    m = vt[-1] / np.linalg.norm(vt[-1][:3])
    return m * np.sign(m[np.argmax(np.abs(m[:3]))])


@pytest.mark.parametrize("name", SHIPPED)
@pytest.mark.parametrize("followers", ["ratio", "axle"])
def test_flip_axle_each_roller(name, followers):
    """flip_axle: the roller's axle → −axle and nothing else moves; the rigid layout keeps exactly one
    motion with the same Ω, the flipped roller's speed counted the other way: its shaft's speed if it is a
    drive roller, its idler speed if it steers, nothing visible for a follower."""
    data = base(name)
    L0 = lt.layout_of(data)
    idlers = [r.name for r in L0.rollers if r.role == "steering"]
    m0 = _rigid_motion(L0, 0.3)
    for r in L0.rollers:
        flipped = lt.flip_axle(data, r.name, followers=followers)
        L1 = lt.layout_of(flipped)
        for a, b in zip(L0.rollers, L1.rollers):
            n0, a0 = pose(a, 0.0)
            n1, a1 = pose(b, 0.0)
            np.testing.assert_allclose(n1, n0, atol=1e-15)
            same_shaft = r.role == "drive" and a.shaft == r.shaft and a.role != "steering"
            flips = a.name == r.name or (same_shaft and (a.role == "drive" or followers == "axle"))
            np.testing.assert_allclose(a1, -a0 if flips else a0, atol=1e-15, err_msg=f"{r.name}: axle of {a.name}")
            if a.role == "follower":
                negated = a.name == r.name or (same_shaft and followers == "ratio")
                assert float(b.ratio) == pytest.approx(-float(a.ratio) if negated else float(a.ratio), rel=1e-15)
        m1 = _rigid_motion(L1, 0.3)
        want = m0.copy()
        if r.role == "drive":
            want[2 + r.shaft] *= -1
        elif r.role == "steering":
            want[5 + idlers.index(r.name)] *= -1
        np.testing.assert_allclose(m1, want, atol=1e-12, err_msg=f"flip_axle({r.name}, followers={followers})")


def test_flip_drive_axle_without_followers_fights():
    """Flipping a box drive roller but leaving its follower as it was: no rigid motion is left."""
    data = base("box_kim")
    with pytest.raises(AssertionError, match="0 rigid motions"):
        _rigid_motion(lt.layout_of(lt.flip_axle(data, "A", followers="none")))


@pytest.mark.slow
@pytest.mark.parametrize("name", SHIPPED)
@GEOMETRY
@given(phi=steering_angles)
def test_flip_fork_and_relabel_keep_poses(name, phi):
    """flip_fork: (−k, −sign) is the same linkage, every pose at every φ equal; relabel_shafts swaps the
    shaft numbers only, and the rigid motion's ω1 and ω2 trade places."""
    data = base(name)
    L0 = lt.layout_of(data)
    for i in range(len(data["steering"]["forks"])):
        L1 = lt.layout_of(lt.flip_fork(data, i))
        for r0, r1 in zip(L0.rollers, L1.rollers):
            for v0, v1 in zip(pose(r0, phi), pose(r1, phi)):
                np.testing.assert_allclose(v1, v0, atol=1e-12)
    L2 = lt.layout_of(lt.relabel_shafts(data))
    for r0, r2 in zip(L0.rollers, L2.rollers):
        assert r2.shaft == (None if r0.shaft is None else 3 - r0.shaft)
        for v0, v2 in zip(pose(r0, phi), pose(r2, phi)):
            np.testing.assert_array_equal(v2, v0)
    m0, m2 = _rigid_motion(L0, phi), _rigid_motion(L2, phi)
    np.testing.assert_allclose(m2[[0, 1, 2, 4, 3]], m0[:5], atol=1e-12)
    np.testing.assert_allclose(m2[5:], m0[5:], atol=1e-12)


def test_set_radius_keeps_follower_consistent():
    """A box drive roller of another radius: its follower's ratio follows, one rigid motion remains."""
    data = lt.set_radius(base("box_kim"), "A", 0.025)
    assert data["rollers"]["A_"]["ratio"] == pytest.approx(0.025 / 0.040, rel=1e-12)
    data = lt.set_radius(data, "A_", 0.055)
    assert data["rollers"]["A_"]["ratio"] == pytest.approx(0.025 / 0.055, rel=1e-12)
    _rigid_motion(lt.layout_of(data), 0.2)
    flipped = lt.flip_axle(data, "A_")
    assert flipped["rollers"]["A_"]["ratio"] == pytest.approx(lt.consistent_ratio(flipped, "A_"), rel=1e-12)


# ==============================================================================================
# 2. the model: same figures, and pointwise where the map is known
# ==============================================================================================

@pytest.mark.slow
@pytest.mark.parametrize("name", SHIPPED + KALKER)
@MODEL
@given(q=quaternions)
@example(q=(np.cos(np.pi / 8), 0.0, 0.0, np.sin(np.pi / 8)))     # 45° about z: d1 → y, d2 → −x
@example(q=(np.cos(np.pi / 4), np.sin(np.pi / 4), 0.0, 0.0))     # 90° about x: the shafts' plane vertical
def test_rotation(name, q):
    """A rotated layout is the same machine: every figure equal, and at every (γ, τ⊥) α, its steering and
    drive parts, the normal forces and the traction utilisation equal (the state is turned with it)."""
    model0, res0, met0 = reference(name)
    model1, res1, met1 = solve(lt.rotate(base(name), lt.quaternion_matrix(q)))
    assert_same_figures(met1, met0, what=f"{name} rotated")
    for k in ANGLES:
        assert_close(res1[k], res0[k], f"{name} rotated: {k} [rad]", atol=ANGLE_TOL)
    for k in ("N", "utilisation", "p_max", "omega_2", "tau_1", "tau_2"):
        assert_close(res1[k], res0[k], f"{name} rotated: {k}", scaled=FORCE_TOL)


def _flip_sign_map(res, s):
    """An envelope array of the original at (s γ, s τ⊥) on its own (symmetric) grid."""
    return res if s == 1 else res[..., ::-1, ::-1]


@pytest.mark.slow
@pytest.mark.parametrize("name", SHIPPED + KALKER)
@MODEL
@given(data=st.data())
def test_axle_and_fork_flips(name, data):
    """Axles of a random subset of rollers declared the other way (followers kept consistent, by ratio or
    by axle) and a random subset of forks written the other way: every figure equal; pointwise
    (γ, τ⊥, α) → (s γ, s τ⊥, s α) with s = s1 s2, and N equal when shaft 1 keeps its sense."""
    names = roller_names(name)
    subset = data.draw(st.lists(st.sampled_from(names), unique=True, min_size=1), label="flip axles")
    mode = data.draw(st.sampled_from(["ratio", "axle"]), label="followers")
    forks = data.draw(st.lists(st.sampled_from(range(len(base(name)["steering"]["forks"]))), unique=True),
                      label="flip forks")
    d = base(name)
    for rn in subset:
        d = lt.flip_axle(d, rn, followers=mode)
    for i in forks:
        d = lt.flip_fork(d, i)
    layout0 = lt.layout_of(base(name))
    drive = {r.shaft: r.name for r in layout0.rollers if r.role == "drive"}
    sense = {sh: -1 if rn in subset else 1 for sh, rn in drive.items()}
    s = sense[1] * sense[2]

    model0, res0, met0 = reference(name)
    model1, res1, met1 = solve(d)
    what = f"{name} flipped axles {subset} (followers by {mode}), forks {forks}"
    assert_same_figures(met1, met0, what=what)
    for k in ANGLES:
        assert_close(res1[k], s * _flip_sign_map(res0[k], s), f"{what}: {k} [rad] at (s γ, s τ⊥), s = {s}",
                     atol=ANGLE_TOL)
    if sense[1] == 1:
        assert_close(res1["N"], _flip_sign_map(res0["N"], s), f"{what}: N [N]", scaled=FORCE_TOL)


@pytest.mark.slow
@pytest.mark.parametrize("name", SHIPPED + KALKER)
@MODEL
@given(q=quaternions, v=directions)
@example(q=(1.0, 0.0, 0.0, 0.0), v=(1.0, 0.0, 0.0))     # x → −x: swaps d1 and −d2 (existing's shaft axes)
def test_mirror_image(name, q, v):
    """A mirror image (fork signs negated) is the same machine seen in a mirror: every figure equal, and
    α, its steering and drive parts equal at the same (γ, τ⊥)."""
    model0, res0, met0 = reference(name)
    model1, res1, met1 = solve(lt.mirror(base(name), reflection(q, v)))
    what = f"{name} mirrored"
    assert_same_figures(met1, met0, what=what)
    for k in ANGLES:
        assert_close(res1[k], res0[k], f"{what}: {k} [rad]", atol=ANGLE_TOL)


@pytest.mark.slow
@pytest.mark.parametrize("name", SHIPPED + KALKER)
@MODEL
@given(q=quaternions, v=directions, data=st.data())
def test_composed_transforms(name, q, v, data):
    """Rotation, an optional mirror and random consistent axle flips together: every figure equal."""
    d = base(name)
    subset = data.draw(st.lists(st.sampled_from(roller_names(name)), unique=True), label="flip axles")
    for rn in subset:
        d = lt.flip_axle(d, rn, followers=data.draw(st.sampled_from(["ratio", "axle"]), label=f"{rn} followers"))
    d = lt.rotate(d, lt.quaternion_matrix(q))
    if data.draw(st.booleans(), label="mirror"):
        d = lt.mirror(d, lt.householder(v))
    _, _, met0 = reference(name)
    _, _, met1 = solve(d)
    assert_same_figures(met1, met0, what=f"{name} rotated, flipped {subset}")


@pytest.mark.parametrize("name", SHIPPED)
def test_relabelled_shafts_pointwise(name):
    """Shafts 1 and 2 swapped (the old brake becomes the motor), relabelled envelope γ 15°..165° in steps
    of 30° (γ = 90° is refused: the motor cannot turn the sphere there): the original's (γ, τ⊥) is the
    relabelled (90° − γ, −τ⊥) for γ > 0 (the same state: N, F, utilisation equal, τ1 and τ2 swapped) and (90° − γ, +τ⊥) for γ < 0 (the reversed state: F and both torques change
    sign); always α → −α, its parts too, and ω2/ω1 → ω1/ω2.

    Tolerance 1e-7 rad on the angles: the model's compliance floor (EPS_RIGID times the motor roller's
    surface speed) is scaled by the other shaft's speed after relabelling; that moves α by ~EPS_RIGID·F."""
    d0 = base(name)
    d1 = lt.set_envelope(lt.relabel_shafts(d0), gamma_deg=(15, 165, 30), load_nm=(-1, 1, 0.5))   # not 90°
    model0 = reference(name)[0]
    model1 = compile_model(lt.layout_of(d1, check=False))
    G, T = np.meshgrid(np.radians([-60.0, -30.0, 30.0, 60.0]), [-1.0, -0.5, 0.5, 1.0], indexing="ij")
    fwd = G > 0
    r0 = model0.evaluate(G, T)
    r1 = model1.evaluate(np.pi / 2 - G, np.where(fwd, -T, T))
    assert r0["ok"].all() and r1["ok"].all(), "relabelled: points not converged"
    what = f"{name} relabelled at (90° − γ, ∓τ⊥)"
    for k in ANGLES:
        assert_close(r1[k], -r0[k], f"{what}: {k} [rad] (expected −original)", atol=1e-7)
    assert_close(r1["omega_2"] / r1["omega_1"], r0["omega_1"] / r0["omega_2"], f"{what}: ω2/ω1 (expected ω1/ω2)",
                 rtol=1e-6)
    sgn = np.where(fwd, 1.0, -1.0)
    assert_close(r1["tau_1"], sgn * r0["tau_2"], f"{what}: τ1 (expected ±τ2 of the original)", scaled=1e-6)
    assert_close(r1["tau_2"], sgn * r0["tau_1"], f"{what}: τ2 (expected ±τ1 of the original)", scaled=1e-6)
    for k in ("F_t", "F_a"):
        assert_close(r1[k], sgn * r0[k], f"{what}: {k} (same state for γ > 0, reversed for γ < 0)", scaled=1e-6)
    for k in ("N", "utilisation"):
        assert_close(r1[k][:, fwd], r0[k][:, fwd], f"{what}, γ > 0: {k}", scaled=1e-6)


# ==============================================================================================
# 3. no load, no slip
# ==============================================================================================

@st.composite
def valid_layouts(draw):
    """A shipped layout, its drive rollers (and a follower, ratio kept consistent) at radii 20–60 mm, then
    rotated, possibly mirrored, with random consistent axle flips."""
    name = draw(st.sampled_from(SHIPPED), label="variant")
    d = lt.set_envelope(lt.read(name), gamma_deg=(-80, 80, 10), load_nm=(0, 0, 1))
    radius = st.floats(0.020, 0.060, allow_nan=False)
    rollers = d["rollers"]
    for rn in [n for n, s in rollers.items() if s["role"] == "drive"]:
        d = lt.set_radius(d, rn, draw(radius, label=f"{rn} radius [m]"))
    followers = [n for n, s in rollers.items() if s["role"] == "follower"]
    if followers:
        d = lt.set_radius(d, draw(st.sampled_from(followers), label="follower"), draw(radius, label="its radius [m]"))
    for rn in draw(st.lists(st.sampled_from(list(rollers)), unique=True), label="flip axles"):
        d = lt.flip_axle(d, rn, followers=draw(st.sampled_from(["ratio", "axle"]), label=f"{rn} followers"))
    d = lt.rotate(d, lt.quaternion_matrix(draw(quaternions, label="rotation q")))
    if draw(st.booleans(), label="mirror"):
        d = lt.mirror(d, lt.householder(draw(directions, label="mirror normal")))
    return d


@pytest.mark.slow
@settings(max_examples=12, **_COMMON)
@given(d=valid_layouts())
def test_zero_load_no_slip(d):
    """At τ⊥ = 0 a valid layout rolls without slip: |α| < 1e-9 rad at every γ of Kim's envelope."""
    model = compile_model(lt.layout_of(d, check=False))
    L = model.layout
    res = model.evaluate(L.gamma_grid, np.zeros_like(L.gamma_grid))
    assert res["ok"].all(), f"{d['name']}: not converged at γ = {np.degrees(L.gamma_grid[~res['ok']])}"
    worst = np.max(np.abs(res["alpha"]))
    assert worst < 1e-9, (f"{d['name']}: |α| = {worst:.3g} rad at τ⊥ = 0 (γ = "
                          f"{np.degrees(L.gamma_grid[np.argmax(np.abs(res['alpha']))]):.0f}°)")


@pytest.mark.parametrize("name", SHIPPED)
@settings(max_examples=8, **_COMMON)
@given(q=quaternions, v=directions, data=st.data())
def test_transformed_layouts_pass_checks(name, q, v, data):
    """A rotated, mirrored, axle- or fork-flipped or relabelled copy of a shipped layout is as valid as the
    original: `load_variant(check=True)` accepts it (the linkage reaches the envelope, one rigid motion)."""
    d = base(name)
    for rn in data.draw(st.lists(st.sampled_from(roller_names(name)), unique=True), label="flip axles"):
        d = lt.flip_axle(d, rn)
    d = lt.rotate(d, lt.quaternion_matrix(q))
    if data.draw(st.booleans(), label="mirror"):
        d = lt.mirror(d, lt.householder(v))
    if data.draw(st.booleans(), label="flip fork 0"):
        d = lt.flip_fork(d, 0)
    if data.draw(st.booleans(), label="relabel shafts"):
        d = lt.set_envelope(lt.relabel_shafts(d), gamma_deg=(15, 165, 30), load_nm=(-1, 1, 1))
    lt.layout_of(d, check=True)
