"""Kalker's FASTSIM (the simplified theory of rolling contact) as a plain numpy reference implementation.

Independent of ``cvtdesign`` (numpy only), so that the package's creep-force laws can be checked against it.

Source
------
J. J. Kalker, "A fast algorithm for the simplified theory of rolling contact", Vehicle System Dynamics 11
(1982) 1-13; J. J. Kalker, *Three-dimensional elastic bodies in rolling contact*, Kluwer, 1990, ch. 3.
Flexibilities as in CONTACT's ``src/m_hertz.f90``, subroutine ``simpflex`` (E. A. H. Vollebregt,
https://github.com/eve70a/CONTACT, Apache-2.0).

Conventions (Kalker)
--------------------
Elliptical contact patch x^2/a^2 + y^2/b^2 <= 1, semi-axis ``a`` along the rolling direction x, ``b`` across
(y). The leading edge of a strip y = const is x = +a(y), a(y) = a sqrt(1 - y^2/b^2); material flows through
the patch from x = +a(y) to the trailing edge x = -a(y). Creepages: ``xi`` (longitudinal), ``eta``
(lateral), dimensionless, and spin ``phi`` [1/m], each = rigid slip velocity of body 1 over body 2 divided
by the rolling speed V, so the rigid slip per unit V is

    w_x = xi - phi y,     w_y = eta + phi x.

Tractions (p_x, p_y) and forces (Fx, Fy) act ON body 1; Mz = int (x p_y - y p_x) dA is their moment about
the patch centre (about +z, z = x cross y). The forces oppose the creepage: Kalker's linear theory is

    Fx = -G a b C11 xi,     Fy = -G a b (C22 eta + sqrt(ab) C23 phi).

Simplified theory
-----------------
The elastic displacement difference is u = L p, with a different flexibility per creepage component,

    L1 = 8 a / (3 G C11),   L2 = 8 a / (3 G C22),   L3 = pi a sqrt(a/b) / (4 G C23),

chosen so that the full-adhesion solution reproduces the linear theory's Fx(xi), Fy(eta) and Fy(phi)
exactly (Kalker 1982). The traction bound is mu p with the simplified theory's parabolic pressure

    p(x, y) = 2 N / (pi a b) (1 - x^2/a^2 - y^2/b^2),     int p dA = N.

In adhesion the slip w - d(L p)/dx vanishes, hence along a strip, marching from the leading edge (p = 0)
towards the trailing edge in steps dx > 0,

    p_x <- p_x - (xi/L1 - phi y/L3) dx,      p_y <- p_y - (eta/L2 + phi x/L3) dx,

and wherever |p| exceeds mu p(x, y) it is scaled back onto the bound (slip). That is FASTSIM (Kalker 1982).
``bound="elliptic"`` takes the Hertz pressure 3 N/(2 pi a b) sqrt(1 - x^2/a^2 - y^2/b^2) as the bound instead,
the choice CONTACT's user guide recommends (the parabolic one allows higher tractions in the patch centre).
Without spin the trial increment has the fixed direction -(xi/L1, eta/L2), so in full slip F points along
-(C11 xi, C22 eta), not along the creepage -(xi, eta) (they differ for C11 != C22; 3.3 deg at a/b = 1,
xi = eta). The spin term of the x-equation uses L3, as in Kalker's algorithm; it gives
no Fx for spin alone (odd in y) but enters Fx for combined creepage and spin, and Mz. Mz is not calibrated
to Kalker's C33 (three flexibilities only); it is returned for information.

Discretisation (this implementation)
------------------------------------
* ``ny`` strips at y_j = -b cos(theta_j), theta_j = (j + 1/2) pi/ny (midpoints in theta, width
  dy_j = b sin(theta_j) pi/ny): the substitution y = -b cos(theta) removes the square-root behaviour of
  a(y) at the lateral edges, so the strip sum converges fast.
* each strip is split into ``nx`` equal elements of length h = 2 a(y)/nx; the traction lives at the element
  midpoints; the step from one midpoint to the next uses the exact integral of the rigid slip over the step
  (the slip is linear in x), so in adhesion the midpoint tractions are exact; the bound of each element is
  the element mean of mu p(x, y), k (a(y)^2 - x^2 - h^2/12), never zero (so a tiny creepage does not
  saturate the trailing element) and summing exactly to mu N over the patch (the strip sum of a(y)^3 is
  exact in theta for ny >= 3), so |F| <= mu N holds to rounding;
* forces are midpoint sums over elements and strips. Linear limit: relative error 7e-10 for xi and eta
  (the strip sum, O(ny^-4)); for phi 1/(2 nx^2) per grid from the x-quadrature of the quadratic adhesion
  traction, -1/nx^2 (-6.25e-6 at nx = 400) after the extrapolation below.
* plain FASTSIM converges only to first order in nx once the traction direction turns along the strip in
  the slip zone (spin, combined creepage): the projection of p - dp onto the bound shortens the rotation
  step by O(dp/|p|) (Vollebregt & Wilders, "FASTSIM2: a second-order accurate frictional rolling contact
  algorithm", Comput. Mech. 47 (2011) 105-116, describe FASTSIM as first-order accurate and give a
  second-order variant; not used here). By default the result is
  therefore Richardson-extrapolated, 2 F(nx) - F(nx/2), which removes that first-order term (measured: the
  plain error halves per doubling of nx, the extrapolated one drops ~4x or more). ``extrapolate=False``
  gives Kalker's plain algorithm on the grid. Each level has |F| <= mu N; the extrapolation could in
  principle overshoot near full slip, but measured it never does beyond rounding (test_saturation).
* ``xi, eta, phi`` broadcast against each other, so a whole creep-force curve is one call.

Defaults ``NX = 400``, ``NY = 200``: see ``test_grid_convergence`` in
tests/validation/test_fastsim_published.py for the measured change when both are doubled.

:func:`fastsim_rectangular` is the same algorithm on CONTACT's rectangular grid of element centres (first
order, no extrapolation), to reproduce CONTACT's printed FASTSIM results case by case
(tests/validation/test_contact_published.py).
"""
from __future__ import annotations

import numpy as np

NX = 400   # elements per strip (rolling direction)
NY = 200   # strips (lateral direction)


def flexibilities(a, b, G, C11, C22, C23):
    """Kalker's simplified-theory flexibilities L1, L2, L3 [m/Pa] (Kalker 1982; CONTACT ``simpflex``)."""
    return (8.0 * a / (3.0 * G * C11),
            8.0 * a / (3.0 * G * C22),
            np.pi * a * np.sqrt(a / b) / (4.0 * G * C23))


def fastsim(a, b, N, mu, G, C11, C22, C23, xi=0.0, eta=0.0, phi=0.0, *, nx=NX, ny=NY, extrapolate=True,
            moment=False, bound="parabolic"):
    """Tangential force of an elliptical rolling contact by FASTSIM (Kalker 1982).

    Parameters
    ----------
    a, b : semi-axes along (x, rolling) and across (y) the rolling direction [m]
    N : normal force [N];  mu : friction coefficient [-];  G : combined shear modulus [Pa]
    C11, C22, C23 : Kalker's linear creep coefficients for a/b and nu [-]
    xi, eta : longitudinal and lateral creepage [-];  phi : spin creepage [1/m]
        (rigid slip of body 1 over body 2 / rolling speed; arrays broadcast together)
    nx, ny : elements per strip (even if ``extrapolate``) and number of strips
    extrapolate : Richardson-extrapolate in nx, 2 F(nx) - F(nx/2) (see the module docstring); False gives
        plain FASTSIM on the nx-by-ny grid
    moment : also return Mz
    bound : traction bound mu p(x, y): "parabolic" (Kalker 1982, the default) or "elliptic" (the Hertz
        pressure; its strip sum falls short of mu N by 6e-10 at NY = 200, so |F| <= mu N holds as well)

    Returns
    -------
    Fx, Fy [N] (and Mz [N m] if ``moment``): force (moment about the patch centre) on body 1, floats for
    scalar input, else arrays of the broadcast shape of (xi, eta, phi).
    """
    xi, eta, phi = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (xi, eta, phi)))
    shape = xi.shape
    if bound not in _BOUNDS:
        raise ValueError(f"bound must be one of {sorted(_BOUNDS)}, not {bound!r}")
    args = (a, b, N, mu, G, C11, C22, C23, xi.reshape(-1, 1), eta.reshape(-1, 1), phi.reshape(-1, 1))
    if extrapolate:
        if nx % 2:
            raise ValueError("nx must be even with extrapolate=True")
        fine, coarse = _sweep(*args, nx, ny, moment, bound), _sweep(*args, nx // 2, ny, moment, bound)
        out = [2.0 * f - c for f, c in zip(fine, coarse)]
    else:
        out = _sweep(*args, nx, ny, moment, bound)
    out = [v.reshape(shape) for v in out]
    return tuple(float(v) if v.ndim == 0 else v for v in out)


def _parabolic_mean(mu, N, a, b, ay, x, h):
    """Element mean of mu p over [x - h/2, x + h/2] on the strip of half-length ay, parabolic pressure."""
    return 2.0 * mu * N / (np.pi * a**3 * b) * (ay * ay - x * x - h * h / 12.0)


def _elliptic_mean(mu, N, a, b, ay, x, h):
    """Element mean of mu p over [x - h/2, x + h/2], Hertz pressure mu p = k sqrt(ay^2 - x^2), k = 3 mu N/(2 pi
    a^2 b): the exact integral (s sqrt(ay^2 - s^2) + ay^2 asin(s/ay))/2 between the element's ends."""
    def primitive(s):
        s = np.clip(s, -ay, ay)
        return 0.5 * (s * np.sqrt(np.maximum(ay * ay - s * s, 0.0)) + ay * ay * np.arcsin(s / ay))
    return 3.0 * mu * N / (2.0 * np.pi * a * a * b) * (primitive(x + 0.5 * h) - primitive(x - 0.5 * h)) / h


_BOUNDS = {"parabolic": _parabolic_mean, "elliptic": _elliptic_mean}


def _sweep(a, b, N, mu, G, C11, C22, C23, xi, eta, phi, nx, ny, moment, bound):
    """Plain FASTSIM on an nx-by-ny grid; xi, eta, phi of shape (m, 1). Returns Fx, Fy[, Mz] of shape (m,)."""
    L1, L2, L3 = flexibilities(a, b, G, C11, C22, C23)
    theta = (np.arange(ny) + 0.5) * np.pi / ny
    w = np.sin(theta)[None, :]                      # sqrt(1 - y^2/b^2) of each strip
    y = -b * np.cos(theta)[None, :]
    dy = b * w * (np.pi / ny)
    ay = a * w                                      # strip half-length a(y)
    h = 2.0 * ay / nx                               # element length
    element_bound = _BOUNDS[bound]

    rx = xi / L1 - phi * y / L3                     # (m, ny): d p_x / dx in adhesion
    ey, sy = eta / L2, phi / L3                     # d p_y / dx = ey + sy x
    px = np.zeros(np.broadcast_shapes(rx.shape, y.shape))
    py = np.zeros_like(px)
    Fx = np.zeros_like(px)
    Fy = np.zeros_like(px)
    Mz = np.zeros_like(px)
    x_prev = ay                                     # leading edge
    for i in range(nx):
        x = ay - (i + 0.5) * h                      # midpoint of element i
        step = x_prev - x                           # h/2 for the first step, then h
        xbar = 0.5 * (x_prev + x)                   # exact mean of the linear slip over the step
        px = px - rx * step
        py = py - (ey + sy * xbar) * step
        limit = element_bound(mu, N, a, b, ay, x, h)   # element mean of mu p (exact integral)
        scale = np.minimum(1.0, limit / np.maximum(np.hypot(px, py), 1e-300))
        px, py = px * scale, py * scale
        Fx += px
        Fy += py
        if moment:
            Mz += x * py - y * px
        x_prev = x
    area = h * dy                                   # element area of each strip
    out = (Fx, Fy, Mz) if moment else (Fx, Fy)
    return tuple((v * area).sum(axis=1) for v in out)


def fastsim_rectangular(a, b, N, mu, flex, xi=0.0, eta=0.0, phi=0.0, *, mx, my, scale=1.1, bound="parabolic"):
    """FASTSIM discretised as CONTACT discretises it, to reproduce CONTACT's printed FASTSIM results.

    CONTACT (E. A. H. Vollebregt, https://github.com/eve70a/CONTACT, Apache-2.0), ``src/m_solvpt.f90``
    ``modif_fastsim`` with slope reduction k = 1, ``src/m_sdis.f90`` ``set_tang_rhs`` and the traction bound of
    ``init_curr_data``: the potential contact [-scale a, scale a] x [-scale b, scale b] is divided into
    mx x my equal elements; an element is in contact where the pressure at its centre is positive; along
    each row, from the leading edge x = +a on (rolling in +x, CONTACT's CHI = 0), the traction at element
    centre i is p_i = p_(i-1) - dx (xi/L1 - phi y/L3, eta/L2 + phi (x_i + dx/6)/L3) (implicit Euler with
    step dq = dx; the spin slip is taken at x_i + dx/6, CONTACT's ``facphi``), scaled back onto mu p(x_i, y)
    where it exceeds it. First order in dx: it is not extrapolated.

    Parameters
    ----------
    a, b : semi-axes [m];  N : normal force [N];  mu : friction coefficient [-]
    flex : (L1, L2, L3) flexibilities [m/Pa], e.g. as CONTACT prints them (FLX1..3, mm^3/N = 1e-9 m/Pa)
    xi, eta : creepages [-];  phi : spin [1/m] (scalars)
    mx, my, scale : CONTACT's MX, MY and SCALE
    bound : "parabolic" (CONTACT's B = 3) or "elliptic" (B = 2), evaluated at the element centres

    Returns
    -------
    Fx, Fy [N], Mz [N m] on body 1, and the number of elements in contact.
    """
    if bound not in _BOUNDS:
        raise ValueError(f"bound must be one of {sorted(_BOUNDS)}, not {bound!r}")
    L1, L2, L3 = flex
    dx, dy = 2.0 * scale * a / mx, 2.0 * scale * b / my
    x = -scale * a + (np.arange(mx) + 0.5) * dx
    y = -scale * b + (np.arange(my) + 0.5) * dy
    r = np.maximum(1.0 - (x[None, :] / a) ** 2 - (y[:, None] / b) ** 2, 0.0)   # (my, mx)
    limit = mu * (2.0 * N / (np.pi * a * b) * r if bound == "parabolic" else
                  3.0 * N / (2.0 * np.pi * a * b) * np.sqrt(r))
    inside = limit > 0.0
    px, py = np.zeros(my), np.zeros(my)
    F = np.zeros(3)
    for i in range(mx - 1, -1, -1):                # leading edge (+x) to trailing edge
        px = np.where(inside[:, i], px - dx * (xi / L1 - phi * y / L3), 0.0)
        py = np.where(inside[:, i], py - dx * (eta / L2 + phi * (x[i] + dx / 6.0) / L3), 0.0)
        s = np.minimum(1.0, limit[:, i] / np.maximum(np.hypot(px, py), 1e-300))
        px, py = px * s, py * s
        F += np.array([px.sum(), py.sum(), (x[i] * py - y * px).sum()])
    Fx, Fy, Mz = F * dx * dy
    return float(Fx), float(Fy), float(Mz), int(inside.sum())


def linear_forces(a, b, G, C11, C22, C23, xi=0.0, eta=0.0, phi=0.0):
    """Kalker's linear theory: Fx = -G a b C11 xi, Fy = -G a b (C22 eta + sqrt(ab) C23 phi) [N]."""
    Gab = G * a * b
    return -Gab * C11 * np.asarray(xi), -Gab * (C22 * np.asarray(eta) + np.sqrt(a * b) * C23 * np.asarray(phi))


def curve(kind, creepages, *, a, b, N, mu, G, C11, C22, C23, nx=NX, ny=NY):
    """Normalised creep-force curve of one creepage component alone, by FASTSIM.

    Parameters
    ----------
    kind : 'longitudinal' (xi alone, force Fx), 'lateral' (eta alone, Fy) or 'spin' (phi alone, Fy)
    creepages : values of xi [-], eta [-] or phi [1/m]
    a, b, N, mu, G, C11, C22, C23, nx, ny : as for :func:`fastsim`

    Returns
    -------
    array of shape (n, 2): columns creepage and F/(mu N), F the force component on body 1 named above,
    signed (Kalker's convention: negative for positive creepage).
    """
    s = np.atleast_1d(np.asarray(creepages, dtype=float))
    args = {"longitudinal": (s, 0.0, 0.0), "lateral": (0.0, s, 0.0), "spin": (0.0, 0.0, s)}
    if kind not in args:
        raise ValueError(f"kind must be one of {sorted(args)}, not {kind!r}")
    Fx, Fy = fastsim(a, b, N, mu, G, C11, C22, C23, *args[kind], nx=nx, ny=ny)
    F = Fx if kind == "longitudinal" else Fy
    return np.column_stack([s, np.broadcast_to(F, s.shape) / (mu * N)])
