"""Rolling-contact fatigue of steel contacts and damage summed over a duty cycle; units SI.

 * L10 of a contact: Lundberg–Palmgren's theory as Loewenthal and Zaretsky apply it to traction drives
   ("Design of traction drives", NASA RP-1154): for a contact of given shape the life goes as the inverse
   n-th power of the Hertz peak pressure, n = (c − h + 2)/e, 9 for a point contact with c = 31/3, h = 7/3,
   e = 10/9. One measured point of the steel (L_ref stress cycles at p_ref, 90 % surviving) fixes it:
   L10 = L_ref (p_ref/p_max)^n stress cycles; a point of the roller's running track is stressed once a turn.
 * Miner's rule (Palmgren–Miner, as gear and bearing tools sum load spectra): each point of a duty cycle uses
   the share t_k/L_k of the life, L_k the life if the machine ran only there; the life over the cycle is
   1 / Σ_k (s_k / L_k) with s_k the point's share of the time.
"""
from __future__ import annotations

import math

import numpy as np


def l10_cycles(p_max, p_ref, cycles_ref, exponent):
    """L10 in stress cycles at Hertz peak pressure p_max [Pa] (module docstring)."""
    return cycles_ref * (p_ref / np.asarray(p_max, float)) ** exponent


def l10_seconds(p_max, V, r, p_ref, cycles_ref, exponent):
    """L10 [s] of a roller's running track (radius r [m], rolling speed V [m/s]: V/(2πr) stress cycles a
    second); inf where it does not roll."""
    rate = np.abs(np.asarray(V, float)) / (2 * math.pi * r)
    with np.errstate(divide="ignore"):
        return np.where(rate > 0, l10_cycles(p_max, p_ref, cycles_ref, exponent) / np.where(rate > 0, rate, 1),
                        np.inf)


def miner_life(lives, shares):
    """The life over a duty cycle (Miner's rule: 1/Σ s_k/L_k) from each point's life L_k (any unit, inf where
    it takes none) and its share s_k of the time [-]; inf when no point takes life."""
    damage = float(np.sum(np.asarray(shares, float) / np.asarray(lives, float)))
    return math.inf if damage == 0 else 1.0 / damage
