"""Rolling-contact fatigue of steel contacts and damage summed over a duty cycle; units SI.

 * L10 of a contact: Lundberg and Palmgren's theory ("Dynamic capacity of rolling bearings", 1947), as
   Loewenthal and Zaretsky apply it to traction drives ("Design of traction drives", NASA RP-1154). The
   probability of survival S of a contact's stressed volume V = a z0 l (a the patch's semi-axis across the
   rolling direction, z0 the depth of the largest orthogonal shear stress τ0, l the running track's length)
   after N stress cycles is ln(1/S) ∝ τ0^c N^e V / z0^h, so at S = 0.9

       L10 ∝ τ0^(−c/e) z0^((h−1)/e) a^(−1/e) l^(−1/e),     c = 31/3, h = 7/3, e = 10/9 (point contact).

   τ0 and z0 follow the patch's shape (Lundberg and Palmgren; Harris, "Rolling bearing analysis"): with b the
   semi-axis along rolling and t the root of b/a = √((t² − 1)(2t − 1)), τ0 = p_max √(2t − 1)/(2t(t + 1)) and
   z0 = b/((t + 1)√(2t − 1)) (a circle: τ0 = 0.214 p_max at 0.351 b; a line contact: 0.25 p_max at 0.5 b).
   At one shape and size L10 goes as p_max^(−n), n = c/e − (h − 1)/e + 1/e = 9 (a given load: Q^(−3)), which
   a material states as `fatigue_exponent`; c/e is then n + (h − 2)/e. One measured contact of the steel
   (L_ref stress cycles at p_ref, with its patch and track: `fatigue_*` constants) fixes the constant:
   L10 = L_ref (τ0,ref/τ0)^(c/e) (z0/z0,ref)^((h−1)/e) (a_ref l_ref/(a l))^(1/e). Without the reference's
   patch and track the contact is taken at the reference's size and shape: L10 = L_ref (p_ref/p_max)^n.
   A point of the roller's running track is stressed once a turn.
 * Miner's rule (Palmgren–Miner, as gear and bearing tools sum load spectra): each point of a duty cycle uses
   the share t_k/L_k of the life, L_k the life if the machine ran only there; the life over the cycle is
   1 / Σ_k (s_k / L_k) with s_k the point's share of the time.
"""
from __future__ import annotations

import math

import numpy as np

H = 7.0 / 3.0           # Lundberg–Palmgren's depth exponent h
E_WEIBULL = 10.0 / 9.0  # their Weibull slope e (point contact)


def _t(ratio):
    """Lundberg–Palmgren's auxiliary t ≥ 1 of patches whose semi-axes (along rolling / across) are `ratio`:
    the root of (t² − 1)(2t − 1) = ratio², by Newton's method from t = 1 + ratio, where the cubic is already
    ≥ 0; it is increasing and convex for t ≥ 1, so the iterates fall monotonically onto the root."""
    r2 = np.asarray(ratio, float) ** 2
    t = 1.0 + np.sqrt(r2)
    for _ in range(100):
        step = ((t * t - 1.0) * (2.0 * t - 1.0) - r2) / (6.0 * t * t - 2.0 * t - 2.0)
        t = t - step
        if np.all(np.abs(step) <= 1e-15 * t):
            break
    return t


def shear_factors(rolling, across):
    """(τ0/p_max, z0/b) of patches with semi-axes `rolling` (b, along rolling) and `across` (a) [m]
    (module docstring)."""
    t = _t(np.asarray(rolling, float) / np.asarray(across, float))
    root = np.sqrt(2.0 * t - 1.0)
    return root / (2.0 * t * (t + 1.0)), 1.0 / ((t + 1.0) * root)


def l10_cycles(p_max, p_ref, cycles_ref, exponent, patch=None, patch_ref=None):
    """L10 in stress cycles at Hertz peak pressure p_max [Pa] (module docstring). `patch`, `patch_ref`: the
    contact's and the reference contact's (semi-axis along rolling, semi-axis across, track length) [m];
    without both, the contact is taken at the reference's size and shape."""
    p_max = np.asarray(p_max, float)
    if patch is None or patch_ref is None:
        return cycles_ref * (p_ref / p_max) ** exponent
    (b, a, l), (b0, a0, l0) = (np.broadcast_arrays(*map(np.asarray, patch)), patch_ref)
    T, Z = shear_factors(b, a)
    T0, Z0 = shear_factors(b0, a0)
    ce = exponent + (H - 2.0) / E_WEIBULL
    return cycles_ref * (T0 * p_ref / (T * p_max)) ** ce * (Z * b / (Z0 * b0)) ** ((H - 1.0) / E_WEIBULL) \
        * (a0 * l0 / (a * l)) ** (1.0 / E_WEIBULL)


def l10_seconds(p_max, V, r, p_ref, cycles_ref, exponent, patch=None, patch_ref=None):
    """L10 [s] of a roller's running track (radius r [m], rolling speed V [m/s]: V/(2πr) stress cycles a
    second); inf where it does not roll. `patch`, `patch_ref` as l10_cycles."""
    rate = np.abs(np.asarray(V, float)) / (2 * math.pi * r)
    with np.errstate(divide="ignore"):
        return np.where(rate > 0, l10_cycles(p_max, p_ref, cycles_ref, exponent, patch, patch_ref)
                        / np.where(rate > 0, rate, 1), np.inf)


def miner_life(lives, shares):
    """The life over a duty cycle (Miner's rule: 1/Σ s_k/L_k) from each point's life L_k (any unit, inf where
    it takes none) and its share s_k of the time [-]; inf when no point takes life."""
    damage = float(np.sum(np.asarray(shares, float) / np.asarray(lives, float)))
    return math.inf if damage == 0 else 1.0 / damage
