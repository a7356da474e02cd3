"""Kalker's exact theory at the hardest contact-points of the shipped kalker envelopes (no computation here).

Source
------
CONTACT, by E. A. H. Vollebregt and J. J. Kalker, open-source version, https://github.com/eve70a/CONTACT,
commit d431cdbd125084c79bd59df83b4ac4c63c570ac9 (2025-07-23, $Revision: 2707 $), Apache-2.0, built for this
project with gfortran (9 portability edits, none numerical) and run as module 3 (basic contact), steady
rolling, Hertzian elliptical patch, one material on both bodies, Coulomb friction, the exact half-space theory
(not FASTSIM). Each value is Richardson-extrapolated from grids of 84 and 44 elements across each axis,
2 F(84) − F(44): CONTACT's exact solution converges to first order in the element size. Against finer grids
(84/164 extrapolated) the values hold to 1.8e-3 at the worst (a pure-longitudinal point) and 5e-4 elsewhere.
The same build reproduces CONTACT's own `fastsim.inp` reference output to every printed digit.

The points: at each ok point of `compare variants/existing.yaml variants/box.yaml --points`,
among the contacts that roll (spin creepage φa < 1000), the one that spins most, the most loaded one, the
most loaded steering roller, and the point an independent review named (D2 at γ = 0°, τ⊥ = −0.6 N·m), or the
largest creepage. Inputs are in Kalker-normalised creepages (core.contact.fastsim): ξ̂ = G a b C11 ξ/(μN),
η̂ = G a b C22 η/(μN), φ̂ = G (ab)^1.5 C23 φ/(μN), with the patch's a/b and combined ν; outputs
(Fx/(μN), Fy/(μN), Mz/(μN a)) on the sphere, Kalker's signs.
"""
from __future__ import annotations

SOURCE = "CONTACT exact theory (eve70a/CONTACT d431cdb), grids 84/44 extrapolated"

# (variant, γ_cmd [°], τ⊥ [N·m], roller, a/b, ν, ξ̂, η̂, φ̂, (Fx/(μN), Fy/(μN), Mz/(μN a)))
POINTS = (
    ("box", 0, -0.1, "B", 1.597618, 0.479369, 7.438298e-01, -3.970496e+00, 2.305332e+01,
     (-0.017916, 0.000251, -0.484412)),
    ("box", -80, 1.0, "A", 1.597618, 0.479369, 1.926581e-01, 3.424445e-01, -4.505466e-01,
     (-0.147431, 0.134725, 0.181994)),
    ("box", 0, -1.0, "N2", 1.564337, 0.479275, 2.878317e-13, 1.290013e-01, -5.652325e-04,
     (-0.000000, -0.123309, 0.044107)),
    ("existing", 0, 0.0, "D2", 1.597618, 0.479369, 5.755669e-09, -1.530121e+01, 9.157778e+01,
     (0.000000, 0.061042, -0.483773)),
    ("existing", 0, 1.0, "D2", 1.597618, 0.479369, 6.662906e-01, -9.760826e-01, 1.056287e+00,
     (-0.348104, -0.200068, -0.329200)),
    ("existing", 10, -1.0, "S2", 1.564337, 0.479275, 1.741349e-11, -3.143625e-01, -5.785394e-02,
     (-0.000000, 0.338640, -0.072721)),
    ("existing", 0, -0.6, "D2", 1.597618, 0.479369, 7.260133e-01, -1.922363e+00, 1.950175e+00,
     (-0.219213, -0.125284, -0.436087)),
)
