"""The creep-force surface that a contact law on Kalker's theory evaluates: FASTSIM with the Hertz traction bound
(core.contact.fastsim), tabulated once for every patch shape and creepage, and evaluated as a smooth cubic
B-spline with exact derivatives.

Why a table. The law must hold wherever the rollers run: a drive roller whose shaft turns slowly under a
fast-spinning sphere reaches spin creepages φa of 10–25, where a closed form with spin (Polach's method)
is up to 0.38 μN off FASTSIM and can even give the lateral force the wrong sign. FASTSIM itself is a grid
algorithm (per-element saturation), neither smooth nor cheap enough for the model's Newton solves. In
Kalker-normalised creepages (core.contact.fastsim) its result depends on (ξ̂, η̂, φ̂) and the patch's a/b
only, so one four-dimensional table covers every contact; Kalker did the same for his exact theory (USETAB,
"Book of tables for the Hertzian creep-force law", 1996).

The table. Creepage space is compactified radially, z = ĉ/(c + √(c² + |ĉ|²)) with ĉ = (ξ̂, η̂, φ̂) and
c = RHO_SCALE: |z| = tanh(asinh(|ĉ|/c)/2), which is analytic at zero creepage (so the spline reproduces linear
theory's slope, to 0.07 %) and approaches 1 like 1 − c/|ĉ| (so creepages up to several hundred keep their
resolution). The unit ball holds every creepage; its surface is full sliding, where the force depends on the
creepage's direction only (the grid's corners outside the ball carry that limit). FASTSIM (nx = 200, ny = 100,
extrapolated) is evaluated on GRID_POINTS nodes along each z axis and at RATIO_NODES, log-uniform in a/b
with factor 2^(1/3); `python -m cvtdesign.core.contact.build_surface` writes it to fastsim_surface.npz
(about 5 minutes). The table stores ξ̂ ≥ 0 and η̂ ≥ 0 only and is unfolded by the law's symmetries:
F(−ξ̂, η̂, φ̂) = (−Fx, Fy, Mz) and F(ξ̂, −η̂, −φ̂) = (Fx, −Fy, −Mz).

The spline. Interpolating uniform cubic B-splines in all four variables (natural end conditions): smooth
(C²), exact at the nodes, with derivatives that are the spline's own, which the model's Newton solves and the
optimiser's implicit derivatives need. Measured against FASTSIM at 4000 random creepages (|ĉ| from 0.01 to
200) and a/b between the nodes: within 0.008 μN in force and 0.005 μN a in moment
(tests/validation/test_surface.py). FASTSIM has kinks (where the patch's adhesion zone vanishes, e.g. at
φ̂ ≈ 0.78 in pure spin at a/b = 1.6); there the spline rounds the corner.

Evaluation. The spline is evaluated by surface.c, compiled once into the model cache (core.native) and
loaded into the process, because CasADi's generic B-spline evaluates it 20–40× slower. Without a C compiler,
CasADi's own `bspline` evaluates the same coefficients (same numbers, slower).
"""
from __future__ import annotations

import ctypes
import functools
import hashlib
from pathlib import Path

import casadi as ca
import numpy as np

from cvtdesign.core import native

DATA = Path(__file__).with_name("fastsim_surface.npz")
SOURCE = Path(__file__).with_name("surface.c")
RHO_SCALE = 1.5                                   # c of the compactification: |ĉ| = 2c at |z| = 1/2
MAPPING = "half-angle"                            # |z| = tanh(asinh(|ĉ|/c)/2) (module docstring)
GRID_POINTS = 41                                  # nodes along each z axis, -1..1
RATIO_NODES = 0.2 * 2.0 ** (np.arange(16) / 3.0)  # a/b from 0.2 to 6.35
OUTPUTS = ("Fx/(μN)", "Fy/(μN)", "Mz/(μN a)")


def compactify(c):
    """z = ĉ/(c + √(c² + |ĉ|²)), c = RHO_SCALE, of normalised creepages ĉ (numpy, shape (3, ...), or a CasADi
    3-vector): smooth everywhere, slope 1/(2c) at zero creepage."""
    if isinstance(c, (ca.SX, ca.MX)):
        return c / (RHO_SCALE + ca.sqrt(RHO_SCALE ** 2 + ca.sumsqr(c)))
    c = np.asarray(c, float)
    return c / (RHO_SCALE + np.sqrt(RHO_SCALE ** 2 + np.sum(c * c, axis=0)))


def expand(z, saturated: float = 1e5):
    """ĉ of compactified creepages z (shape (3, ...)); points on or outside the unit sphere become the
    direction's full-sliding limit, |ĉ| = `saturated`."""
    z = np.asarray(z, float)
    r = np.sqrt(np.sum(z * z, axis=0))
    rho = np.where(r < 1.0 - 1e-4, 2.0 * RHO_SCALE * r / np.maximum(1.0 - r * r, 1e-12), saturated)
    return z * np.where(r > 0, rho / np.maximum(r, 1e-300), 1.0)


def grid() -> np.ndarray:
    return np.linspace(-1.0, 1.0, GRID_POINTS)


def unfold(quarter: np.ndarray) -> np.ndarray:
    """Values on the whole z cube, (..., 3, n, n, n), from the stored ξ̂ ≥ 0, η̂ ≥ 0 part (..., 3, h, h, n) with
    h = (n + 1)/2, by the symmetries of the module docstring."""
    fx, fy, mz = (quarter[..., k, :, :, :] for k in range(3))
    flip_xi = np.stack([-fx[..., :0:-1, :, :], fy[..., :0:-1, :, :], mz[..., :0:-1, :, :]], axis=-4)
    half = np.concatenate([flip_xi, quarter], axis=-3)                 # the whole ξ̂ axis
    mirrored = half[..., :, :0:-1, ::-1] * np.array([1.0, -1.0, -1.0])[:, None, None, None]
    return np.concatenate([mirrored, half], axis=-2)                   # the whole η̂ axis (φ̂ reversed with it)


def spline_matrix(n: int) -> np.ndarray:
    """The (n + 2) × n matrix that takes values at n uniform nodes to the coefficients c_-1..c_n of the uniform
    cubic B-spline through them (natural ends: c_-1 − 2c_0 + c_1 = 0 and the same at the far end); `coefficients`
    applies it along each axis of the table."""
    A = np.zeros((n + 2, n + 2))
    A[0, :3] = A[-1, -3:] = (1.0, -2.0, 1.0)
    for i in range(n):
        A[i + 1, i:i + 3] = (1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0)
    return np.linalg.solve(A, np.eye(n + 2)[:, 1:n + 1])     # the interpolation conditions' right-hand sides


@functools.cache
def coefficients() -> np.ndarray:
    """The spline's coefficients, C-ordered [output][log a/b][z2][z1][z0] (what surface.c reads)."""
    with np.load(DATA) as data:
        quarter = data["values"].astype(float)             # (ratio, output, ξ̂ ≥ 0, η̂ ≥ 0, φ̂)
        if not (np.allclose(data["ratio_nodes"], RATIO_NODES) and float(data["rho_scale"]) == RHO_SCALE
                and str(data["mapping"]) == MAPPING and int(data["grid_points"]) == GRID_POINTS):
            raise RuntimeError(f"{DATA.name} was built for another grid: rebuild it (build_surface)")
    return spline_coefficients(unfold(quarter))


def spline_coefficients(values: np.ndarray) -> np.ndarray:
    """The coefficients of the spline through `values` (ratio, output, z0, z1, z2), C-ordered [output][ratio][z2]
    [z1][z0]: spline_matrix applied along each of the four axes, by one matrix product an axis (each moves its
    axis to the end: the ratio's, then z2's, z1's and z0's)."""
    c = values
    for axis in (0, 3, 2, 1):
        c = np.tensordot(c, spline_matrix(c.shape[axis]), axes=(axis, 1))
    return np.ascontiguousarray(c)


def evaluate(z, ratio) -> np.ndarray:
    """The spline at compactified creepages z (3, m) and a/b `ratio` (scalar or (m,)), in numpy: (3, m), the
    same numbers as the compiled law (for plots, the `contact` command and tests)."""
    z = np.asarray(z, float).reshape(3, -1)
    lr = np.broadcast_to(np.log(np.asarray(ratio, float)), z.shape[1:])
    c = coefficients()
    axes = [((lr - np.log(RATIO_NODES[0])) / _r_step(), c.shape[1])] + \
           [((z[k] + 1.0) / _z_step(), c.shape[2]) for k in (2, 1, 0)]           # c's order: ratio, z2, z1, z0
    cells, weights = [], []
    for u, size in axes:
        cell = np.clip(np.floor(u), 0, size - 4).astype(int)
        t = u - cell
        cells.append(cell)
        weights.append([(1 - t) ** 3 / 6, (3 * t ** 3 - 6 * t ** 2 + 4) / 6, (-3 * t ** 3 + 3 * t ** 2 + 3 * t + 1) / 6,
                        t ** 3 / 6])
    out = np.zeros((3, z.shape[1]))
    for q in np.ndindex(4, 4, 4, 4):
        w = weights[0][q[0]] * weights[1][q[1]] * weights[2][q[2]] * weights[3][q[3]]
        out += c[:, cells[0] + q[0], cells[1] + q[1], cells[2] + q[2], cells[3] + q[3]] * w
    return out


def _z_step() -> float:
    return 2.0 / (GRID_POINTS - 1)


def _r_step() -> float:
    return float(np.log(RATIO_NODES[1] / RATIO_NODES[0]))


@functools.cache
def law_functions() -> tuple[ca.Function, ca.Function]:
    """What the model calls at each contact, as CasADi Functions of (z+ [3], z− [3], log(a/b), w): the spline at
    the creepages of the two rolling senses, weighted, w f(z+) + (1 − w) f(z−) with f(z−)'s moment negated (the
    moment's sign follows σ; core.contact.laws: w is 0 or 1 except at a contact that barely rolls, and only the
    side that counts is evaluated); and the same with its exact Jacobian in each argument, in one evaluation. surface.c loaded into this process (module docstring),
    else CasADi's bspline."""
    return _library()[1:]


def spline_function() -> ca.Function:
    """The spline itself, (z [3], log(a/b)) → (Fx/(μN), Fy/(μN), Mz/(μN a)), with its exact Jacobian."""
    return _library()[0]


@functools.cache
def _library() -> tuple[ca.Function, ca.Function, ca.Function]:
    c = coefficients()
    digest = hashlib.sha256(c.tobytes() + SOURCE.read_bytes()).hexdigest()[:12]
    name = f"cvtdesign_surface_{digest}"
    library = native.shared_library(SOURCE.read_text().replace("SURFACE", name))
    if library is None:
        return _casadi_spline(c, name)
    handle = ctypes.CDLL(str(library), mode=ctypes.RTLD_GLOBAL)    # compiled models resolve `name` here
    getattr(handle, f"{name}_init")(c.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), ctypes.c_int(c.shape[2]),
                                    ctypes.c_int(c.shape[1]), ctypes.c_double(_z_step()),
                                    ctypes.c_double(np.log(RATIO_NODES[0])), ctypes.c_double(_r_step()))
    # the Jacobian's own derivatives (a Jacobian of the model's Jacobian: the dynamic model's linearisation in an
    # optimisation, design.dynamic_rows) by central differences of the exact Jacobian
    fd = {"enable_fd": True, "fd_method": "central"}
    return tuple(ca.external(n, str(library), fd if n.endswith("_jac_value") else {})
                 for n in (name, f"{name}_pair", f"{name}_pair_jac_value"))


def _casadi_spline(c: np.ndarray, name: str) -> tuple[ca.Function, ca.Function, ca.Function]:
    """The same functions by CasADi's B-spline node (uniform knots one step beyond each end, as surface.c), which
    evaluates both sides of a pair."""
    nz, nr = c.shape[2], c.shape[1]
    hz, hr, r0 = _z_step(), _r_step(), float(np.log(RATIO_NODES[0]))
    knots = [list(-1.0 + hz * np.arange(-3, nz + 1))] * 3 + [list(r0 + hr * np.arange(-3, nr + 1))]
    flat = np.transpose(c, (0, 4, 3, 2, 1)).ravel(order="F")     # output fastest, then z0, z1, z2, ratio
    z, lr = ca.MX.sym("z", 3), ca.MX.sym("log_ratio")
    value = ca.bspline(ca.vertcat(z, lr), ca.DM(flat), knots, [3, 3, 3, 3], 3, {"lookup_mode": ["exact"] * 4})
    single = ca.Function(name, [z, lr], [value], {"never_inline": True})
    zp, zm, w = ca.MX.sym("z_plus", 3), ca.MX.sym("z_minus", 3), ca.MX.sym("w")
    both = w * single(zp, lr) + (1 - w) * ca.vertcat(1, 1, -1) * single(zm, lr)
    args = [zp, zm, lr, w]
    return (single, ca.Function(f"{name}_pair", args, [both], {"never_inline": True}),
            ca.Function(f"{name}_pair_jac_value", args, [both, *(ca.jacobian(both, a) for a in args)]))
