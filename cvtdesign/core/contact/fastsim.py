"""Kalker's simplified theory of rolling contact (FASTSIM), in Kalker-normalised creepages, with the Hertz
(elliptic) traction bound: the reference from which the contact law's creep-force surface is built
(core.contact.surface).

Normalisation. On an elliptical patch (semi-axis a along the rolling direction x, b across it, a/b = r) with
Coulomb friction μ and normal force N, write the creepages in units of linear theory's saturation:

    ξ̂ = G a b C11 ξ / (μN),   η̂ = G a b C22 η / (μN),   φ̂ = G (ab)^(3/2) C23 φ / (μN),

so that linear theory reads F/(μN) = −(ξ̂, η̂ + φ̂). With FASTSIM's flexibilities L1 = 8a/(3 G C11),
L2 = 8a/(3 G C22), L3 = π a √(a/b)/(4 G C23) (Kalker 1982, chosen so that full adhesion reproduces linear
theory) and the traction scaled by the peak bound μ p0 = 3μN/(2π ab), positions by a and b, the strip
equations become

    dp̂x/dx̂ = (π/4) ξ̂ − (8/3)(1/r) φ̂ ŷ,     dp̂y/dx̂ = (π/4) η̂ + (8/3) φ̂ x̂,     |p̂| ≤ √(1 − x̂² − ŷ²),

in which G, ν, N, μ and the patch's size no longer appear. So F/(μN) and Mz/(μN a) are functions of
(ξ̂, η̂, φ̂) and the patch's shape r alone: a four-dimensional table serves every contact of every layout.

Discretisation (as in the project's independent reference, with its own code): strips ŷ = −cos θ at the
midpoints of θ (which removes the square-root behaviour of the strip length at the patch's sides), each cut
into `nx` equal elements; the step between element midpoints integrates the rigid slip exactly; each element's
bound is its exact mean of the Hertz pressure; the result is Richardson-extrapolated in nx, 2F(nx) − F(nx/2),
since FASTSIM converges to first order once the traction turns in the slip zone. At nx = 200, ny = 100 the
forces are converged to 6e-5 μN (against nx = 800, ny = 400).

Forces and moment act on body 1 (the sphere), Kalker's sign convention: Mz about z = x × y, the patch normal.

References: J. J. Kalker, "A fast algorithm for the simplified theory of rolling contact", Vehicle System
Dynamics 11 (1982) 1–13; J. J. Kalker, *Three-dimensional elastic bodies in rolling contact*, Kluwer, 1990,
ch. 3; CONTACT's user guide (E. A. H. Vollebregt) for the elliptic traction bound.
"""
from __future__ import annotations

import numpy as np

NX, NY = 200, 100        # elements per strip and strips: converged to 6e-5 μN with the extrapolation
CHUNK = 4096             # points swept at once (memory: CHUNK × NY doubles a state array)


def fastsim(xi_hat, eta_hat, phi_hat, ratio, nx: int = NX, ny: int = NY):
    """(Fx/(μN), Fy/(μN), Mz/(μN a)) by FASTSIM with the Hertz traction bound, Richardson-extrapolated in nx.

    Parameters
    ----------
    xi_hat, eta_hat, phi_hat : Kalker-normalised creepages (module docstring) [-]; arrays broadcast together
    ratio : a/b of the patch [-]
    nx, ny : elements per strip (even) and strips

    Returns
    -------
    three arrays of the broadcast shape: the force along x and y over μN, the moment about the normal over μN a.
    """
    xi_hat, eta_hat, phi_hat = np.broadcast_arrays(*(np.asarray(v, float) for v in (xi_hat, eta_hat, phi_hat)))
    flat = [v.ravel() for v in (xi_hat, eta_hat, phi_hat)]
    out = np.empty((3, flat[0].size))
    for s in range(0, flat[0].size, CHUNK):
        part = [v[s:s + CHUNK, None] for v in flat]
        fine, coarse = _sweep(*part, ratio, nx, ny), _sweep(*part, ratio, nx // 2, ny)
        out[:, s:s + CHUNK] = 2.0 * fine - coarse
    return tuple(v.reshape(xi_hat.shape) for v in out)


def _element_bound(x, half_length, h):
    """Mean of √(w² − x²) over the element [x − h/2, x + h/2] of a strip of half-length w (exact integral)."""
    def primitive(s):
        s = np.clip(s, -half_length, half_length)
        return 0.5 * (s * np.sqrt(np.maximum(half_length ** 2 - s * s, 0.0))
                      + half_length ** 2 * np.arcsin(s / half_length))
    return (primitive(x + 0.5 * h) - primitive(x - 0.5 * h)) / h


def _sweep(xi_hat, eta_hat, phi_hat, ratio, nx, ny):
    """Plain FASTSIM on nx × ny elements for creepages of shape (m, 1): array (3, m)."""
    theta = (np.arange(ny) + 0.5) * np.pi / ny
    w = np.sin(theta)[None, :]                  # strip half-length √(1 − ŷ²)
    y = -np.cos(theta)[None, :]
    h = 2.0 * w / nx
    rx = 0.25 * np.pi * xi_hat - (8.0 / 3.0) / ratio * phi_hat * y
    ey, sy = 0.25 * np.pi * eta_hat, (8.0 / 3.0) * phi_hat
    px = np.zeros(np.broadcast_shapes(rx.shape, y.shape))
    py, fx, fy, mz = (np.zeros_like(px) for _ in range(4))
    x_prev = w                                  # leading edge
    for i in range(nx):
        x = w - (i + 0.5) * h
        px = px - rx * (x_prev - x)
        py = py - (ey + sy * 0.5 * (x_prev + x)) * (x_prev - x)
        scale = np.minimum(1.0, _element_bound(x, w, h) / np.maximum(np.hypot(px, py), 1e-300))
        px, py = px * scale, py * scale
        fx += px
        fy += py
        mz += x * py - (y / ratio) * px
        x_prev = x
    area = (3.0 / (2.0 * np.pi)) * h * w * (np.pi / ny)
    return np.stack([(v * area).sum(axis=1) for v in (fx, fy, mz)])
