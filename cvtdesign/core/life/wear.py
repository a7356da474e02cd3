"""Wear of a roller's running track from the frictional work of its contact (creep and spin); units SI.

Archard's law in its energy form (the form of Grosch's abrasion of rubber and of the railway wear indices
Tγ): the volume worn is the wear coefficient k [m³/J] times the frictional energy dissipated at the patch,
creep and spin together (the contact's power lost to friction, core.equations `loss`). Each pass of the
patch takes it from the roller's running track, a band of the roller's circumference 2πr and the patch's
width 2b along the axle, so the track wears evenly to a depth

    h = k·W_f / (2πr · 2b),     dh/dt = k·P_f / (4π r b).
"""
from __future__ import annotations

import math


def wear_depth(k, work, r, b):
    """Depth worn [m] from the frictional energy `work` [J] over a running track of radius r and patch
    half-width b [m] (module docstring)."""
    return k * work / (4.0 * math.pi * r * b)


def wear_rate(k, power, r, b):
    """Depth worn per second [m/s] at frictional power `power` [W]."""
    return k * power / (4.0 * math.pi * r * b)
