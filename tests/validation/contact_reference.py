"""Reference results of CONTACT, transcribed from its example runs (no computation here).

Source
------
CONTACT, "detailed investigation of 3D frictional contact problems", by E. A. H. Vollebregt and J. J. Kalker,
open-source version, https://github.com/eve70a/CONTACT, commit d431cdbd125084c79bd59df83b4ac4c63c570ac9
(2025-07-23, "update ref_out"). Each .ref_out file's header reads "Version: open(win64), $Revision: 2707 $,
$Date:: 2025-07-23$". CONTACT is licensed under the Apache License 2.0 (Copyright Vtech CMCC); the numbers
below are copied from its files examples/tractcurv.inp, tractcurv.ref_out, fastsim.inp, fastsim.ref_out,
carter2d.inp and carter2d.ref_out, and the input formats and conventions from doc/user-guide.tex.

Units and conventions are CONTACT's, as printed: lengths in mm, forces in N, moduli in N/mm^2, moments in
N mm, spin CPHI in 1/mm. Creepages CKSI, CETA, CPHI are the rigid slip of body 1 over body 2 divided by
the rolling speed; forces FX, FY and moment MZ act on body 1 and oppose the creepage (positive CKSI gives
negative FX), as in Kalker's theory and tests/validation/fastsim.py. CHI = 0: rolling in +x, so the
leading edge is x = +a. FX/FSTAT/FN is CONTACT's normalised force F/(mu N). Values carry the four
significant digits CONTACT prints.

CONTACT's SENSITIVITIES blocks (DF/DKSI, ...) are all zero ("not calculated") in these runs, so the linear
slope is taken from the smallest-creepage case instead.
"""
from __future__ import annotations

VERSION = "CONTACT open source, $Revision: 2707 $, $Date:: 2025-07-23$ (eve70a/CONTACT commit d431cdb)"

# --- examples/tractcurv.inp: creep-force curves, pure longitudinal creepage ----------------------------
# The Eurosprinter case of Polach 2005 and Vollebregt 2014 (wheel radius 625 mm, 106.7 kN per wheel,
# V = 10 m/s), with a/b = 0.5 (IPOTCN = -2: curvature A1 and AA/BB given; CONTACT prints the Hertz
# solution below). Cases 1-30: CONTACT's exact half-space theory (Kalker's original), Coulomb friction
# (M = 0, L = 0). Cases 61-90: original FASTSIM (M = 3, parabolic traction bound B = 3, slope reduction
# K0_MF = ALFAMF = 1, i.e. none). Cases 31-60 and 91-120 (falling friction, interface layer, modified
# FASTSIM) are not transcribed: that physics is not cvtdesign's.
TRACTCURV = dict(
    FN=106700.0,            # N
    FSTAT=0.33,             # Coulomb friction (FSTAT = FKIN)
    GG=82000.0,             # N/mm^2, both bodies
    POISS=0.28,             # both bodies
    A1=0.8000e-3,           # 1/mm, input curvature along x (1/(2 R), R = 625 mm)
    B1=0.2814e-3,           # 1/mm, as printed ("THE CURVATURES A1,B1 ARE")
    AA=6.304,               # mm, "BASIC SEMIAXES AA,BB"
    BB=12.61,               # mm
    MX=48, MY=44, SCALE=1.1,
    VELOC=10000.0,          # mm/s
)
# FLX1, FLX2, FLX3 [mm^3/N] printed by case 61 (FASTSIM's three flexibilities; CONTACT's simpflex). For pure
# longitudinal creepage only FLX1 is used; FLX2, FLX3 carry CONTACT's blending towards one flexibility with
# weight f_crp/3 = 1.5e-3 at CKSI = 1e-5.
TRACTCURV_FLX = (0.5491e-4, 0.6773e-4, 0.4526e-4)

# (case, CKSI [-], FX/FSTAT/FN [-])
TRACTCURV_EXACT = (
    (1, 1e-05, -7.015e-03),
    (2, 0.0004, -0.2588),
    (3, 0.0008, -0.4742),
    (4, 0.0012, -0.6482),
    (5, 0.0016, -0.7831),
    (6, 0.002, -0.8816),
    (7, 0.0024, -0.9467),
    (8, 0.0028, -0.9832),
    (9, 0.0032, -0.9976),
    (10, 0.0036, -0.9991),
    (11, 0.004, -0.9993),
    (12, 0.0044, -0.9994),
    (13, 0.0048, -0.9995),
    (14, 0.0052, -0.9996),
    (15, 0.0056, -0.9996),
    (16, 0.006, -0.9997),
    (17, 0.008, -0.9998),
    (18, 0.01, -0.9999),
    (19, 0.02, -1.0000),
    (20, 0.03, -1.0000),
    (21, 0.04, -1.0000),
    (22, 0.05, -1.0000),
    (23, 0.075, -1.0000),
    (24, 0.1, -1.0000),
    (25, 0.125, -1.0000),
    (26, 0.15, -1.0000),
    (27, 0.175, -1.0000),
    (28, 0.2, -1.0000),
    (29, 0.225, -1.0000),
    (30, 0.25, -1.000),
)
TRACTCURV_EXACT_FX1 = -247.0     # N, FX of case 1 (CKSI = 1e-5), the linear slope's four digits

TRACTCURV_FASTSIM = (
    (61, 1e-05, -7.126e-03),
    (62, 0.0004, -0.2577),
    (63, 0.0008, -0.4653),
    (64, 0.0012, -0.6281),
    (65, 0.0016, -0.7521),
    (66, 0.002, -0.8433),
    (67, 0.0024, -0.9075),
    (68, 0.0028, -0.9505),
    (69, 0.0032, -0.9770),
    (70, 0.0036, -0.9915),
    (71, 0.004, -0.9978),
    (72, 0.0044, -0.9998),
    (73, 0.0048, -1.000),
    (74, 0.0052, -1.000),
    (75, 0.0056, -1.000),
    (76, 0.006, -1.000),
    (77, 0.008, -1.000),
    (78, 0.01, -1.000),
    (79, 0.02, -1.000),
    (80, 0.03, -1.000),
    (81, 0.04, -1.000),
    (82, 0.05, -1.000),
    (83, 0.075, -1.000),
    (84, 0.1, -1.000),
    (85, 0.125, -1.000),
    (86, 0.15, -1.000),
    (87, 0.175, -1.000),
    (88, 0.2, -1.000),
    (89, 0.225, -1.000),
    (90, 0.25, -1.000),
)

# --- examples/fastsim.inp: lateral creepage with spin, one case by several methods ----------------------
# Hertzian semi-axes given (IPOTCN = -3), a/b = 2; CKSI = 0, CETA = -6.25e-4, CPHI = 6.25e-4 1/mm, CHI = 0.
FASTSIM_CASE = dict(
    FN=82000.0, FSTAT=0.30, GG=82000.0, POISS=0.28, AA=8.0, BB=4.0, SCALE=1.1, VELOC=30000.0,
    CKSI=0.0, CETA=-6.25e-4, CPHI=6.25e-4,
)
# FLX1..3 [mm^3/N] printed by the FASTSIM cases: CONTACT's flexibilities after its blending (weight ~0.08 here)
FASTSIM_FLX = (0.4937e-4, 0.5152e-4, 0.4090e-4)

# case: (method, traction bound, MX = MY, FY [N], MZ [N mm], FY/FSTAT/FN, elements in contact). FX = 0 in all.
# "exact" = CONTACT's half-space theory (M = 0, B = 0). Cases 4 and 7 (FaStrip) are not transcribed.
FASTSIM_RESULTS = {
    1: ("exact", "hertz", 44, -1.494e4, -4.821e4, -0.6074, 1276),
    2: ("fastsim", "parabolic", 44, -1.505e4, -3.900e4, -0.6118, 1264),
    3: ("fastsim", "elliptic", 44, -1.480e4, -4.829e4, -0.6016, 1264),
    5: ("fastsim", "parabolic", 220, -1.564e4, -3.798e4, -0.6359, 31428),
    6: ("fastsim", "elliptic", 220, -1.465e4, -4.530e4, -0.5956, 31428),
}

# --- examples/carter2d.inp: Carter's two-dimensional rolling problem ---------------------------------------
# Half width a = 1 mm (PMAX = 113.9 N/mm^2), combined radius 500 mm (B1 = 0.001 1/mm = 1/(2 R)), 50 elements
# over the contact, a strip of width DY = 200 mm carrying FN = 35780 N; the input comment gives Carter's
# answer a'/a = 0.6, F = 0.64 FSTAT FN at CKSI = -0.024 %.
CARTER2D = dict(FN=35780.0, FSTAT=0.30, GG=82000.0, POISS=0.28, HALF_WIDTH=1.0, RADIUS=500.0,
                CKSI=-2.4e-4, FX=6955.0, FX_N=0.6480)
