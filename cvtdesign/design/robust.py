"""Robust design: the worst case over the calibration's confidence region (a study's `robust:`).

The calibration of the contact law is known to a standard deviation (docs/materials.md): the drive and
steering compliance scales θ = (s_D, s_S) of `drive_longitudinal_creep` and `steering_lateral_creep` have the
covariance Σ of core.uncertainty.covariance (σ of each role's calibration; fully correlated when both rest
on one calibration). A robust study minimises the worst |α| over a confidence region of θ, with every
constraint held there too.

The region is the box, in Σ's principal axes, that holds θ with probability `confidence`: for k independent
components (k = 1 when the roles are fully correlated, else 2) each ±z·√λ with z = Φ⁻¹((1 + c^(1/k))/2)
(z = 1.96 for k = 1 at 95 %, 2.236 for k = 2). Its 2^k corners are the scenarios: slip, forces and
utilisation grow monotonically with each compliance over such small ranges, so their worst over the box is at
a corner (the nominal θ lies inside). Every envelope point is then a point at each corner (design.problem).
"""
from __future__ import annotations

import itertools
from statistics import NormalDist

import numpy as np

from cvtdesign.core.inputs import SCALES
from cvtdesign.core.uncertainty import covariance
from cvtdesign.errors import InputError


def scenarios(model, robust, where: str) -> tuple[np.ndarray, list[str]]:
    """(θ of each scenario (S × len(θ)), a label each) of a study's `robust` setting (None: the nominal θ
    alone, S = 1) for a compiled model whose θ carries the calibration's scales."""
    theta = np.asarray(model.param_values, float)
    if robust is None:
        return theta[None, :], [""]
    cov = covariance(model)
    scale_idx = [model.param_names.index(s) for s in SCALES.values() if s in model.param_names]
    if cov is None or not scale_idx:
        raise InputError(f"{where}: robust: over calibration: the base variant's creep compliance has no stated "
                         "uncertainty (a THEORY ONLY contact, or fitted constants without contact.uncertainty); "
                         "expected a calibrated variant (docs/materials.md)")
    idx, sigma = cov
    keep = [i for i, j in enumerate(idx) if j in scale_idx]      # the calibration's scales only
    idx, sigma = [idx[i] for i in keep], sigma[np.ix_(keep, keep)]
    lam, vec = np.linalg.eigh(sigma)
    axes = [(np.sqrt(lv), vec[:, i]) for i, lv in enumerate(lam) if lv > 1e-12 * lam.max()]
    z = NormalDist().inv_cdf((1 + robust.confidence ** (1 / len(axes))) / 2)
    out, labels = [], []
    for signs in itertools.product((-1.0, 1.0), repeat=len(axes)):
        th = theta.copy()
        th[idx] += sum(s * z * sd * v for s, (sd, v) in zip(signs, axes))
        out.append(th)
        labels.append(", ".join(f"{model.param_names[j].split('.')[0].split('_')[0]} ×{th[j] / theta[j]:.3f}"
                                for j in idx))
    return np.array(out), labels
