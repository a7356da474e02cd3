"""The diagnosis's three significance tests, from numpy and scipy.special alone: the χ² survival function, the
one-way ANOVA and the one-sided Wilcoxon signed-rank test. Each reproduces the scipy.stats function named in its
docstring, by the same method and the same arithmetic (tests/unit/diagnosis/test_significance.py checks them
against scipy.stats on random data with ties and zeros), because importing scipy.stats costs about a third of a
second of a `cvtdesign diagnose` run (its distributions, built at import, are more than the diagnosis needs);
scipy.special, which holds the distribution functions scipy.stats itself calls, is loaded anyway by the fit
(scipy.optimize.least_squares)."""
from __future__ import annotations

from itertools import product

import numpy as np
from scipy.special import chdtrc, fdtrc, ndtr

EXACT_MAX = 50        # at most this many differences, without ties or zeros: the exact null distribution
PERMUTED_MAX = 13     # at most this many, with ties or zeros: every sign flip (2¹³ ≤ scipy's 9999 resamples)


def chi2_sf(stat: float, dof: int) -> float:
    """P(χ²_dof ≥ stat), as scipy.stats.chi2.sf(stat, dof) (which returns scipy.special.chdtrc(dof, stat) for
    stat > 0, 1 at 0)."""
    return float(chdtrc(dof, stat)) if stat > 0 else 1.0


def f_oneway(*samples) -> tuple[float, float]:
    """(F, p) of the one-way ANOVA of the samples (finite 1-D arrays, equal variances), as
    scipy.stats.f_oneway(*samples) in scipy 1.17: the same sums in the same order, F = inf where every sample
    is constant (and not all the same), NaN where every value is the same, and (NaN, NaN) where a sample is
    empty or every sample has one value."""
    samples = [np.asarray(s, dtype=float) for s in samples]
    if len(samples) < 2:
        raise TypeError(f"at least two inputs are required; got {len(samples)}.")
    if any(s.size == 0 for s in samples) or all(s.size == 1 for s in samples):
        return np.nan, np.nan
    alldata = np.concatenate(samples)
    bign = alldata.size
    all_const = all(bool(np.all(np.diff(s) == 0)) for s in samples)
    all_same_const = bool(np.all(np.diff(alldata) == 0))
    offset = np.mean(alldata, keepdims=True)
    alldata = alldata - offset
    normalized_ss = np.sum(alldata) ** 2. / bign
    sstot = np.dot(alldata, alldata) - normalized_ss        # np.vecdot in scipy: the same sum (numpy ≥ 2)
    ssbn = 0
    for s in samples:
        ssbn = ssbn + np.sum(s - offset) ** 2. / s.size
    ssbn = ssbn - normalized_ss
    sswn = sstot - ssbn
    dfbn, dfwn = len(samples) - 1, bign - len(samples)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = (ssbn / dfbn) / (sswn / dfwn)
    f = np.nan if all_same_const else np.inf if all_const else float(f)
    return f, float(fdtrc(dfbn, dfwn, f))


def wilcoxon_greater(d) -> tuple[float, float]:
    """(R⁺, p) of the one-sided Wilcoxon signed-rank test that the differences d (finite, 1-D) lie above 0,
    zeros split between the signs: scipy.stats.wilcoxon(d, alternative="greater", zero_method="zsplit") with
    its defaults (method "auto", no continuity correction) in scipy 1.17. R⁺ is the sum of the ranks of |d|
    (ties averaged) of the positive differences plus half those of the zeros. Its p-value, by scipy's choice:
    - more than EXACT_MAX differences: the normal approximation, z = (R⁺ − n(n+1)/4)/σ with
      σ² = (n(n+1)(2n+1) − Σ(t³ − t)/2)/24 over the groups of t tied |d| (the zeros one of them);
    - at most EXACT_MAX, no ties and no zeros: the exact null distribution of R⁺, at ⌊R⁺⌋;
    - at most PERMUTED_MAX with ties or zeros: the share of the 2ⁿ sign flips of d whose R⁺ reaches it;
    - otherwise the normal approximation."""
    d = np.asarray(d, dtype=float)
    n = d.size
    if n == 0:
        return np.nan, np.nan
    r, ties = _ranks(np.abs(d))
    zeros = d == 0
    r_zero_2 = np.sum(zeros.astype(float) * r) / 2
    r_plus = np.sum((d > 0).astype(float) * r) + r_zero_2
    if n <= EXACT_MAX and not (ties.size or zeros.any()):
        return float(r_plus), _exact_sf(n, int(np.floor(r_plus)))
    if n <= PERMUTED_MAX:
        return float(r_plus), _sign_flip_sf(d, r, r_zero_2, r_plus)
    count = float(n)
    mn = count * (count + 1.) * 0.25
    se = np.sqrt((count * (count + 1.) * (2. * count + 1.) - np.sum(ties ** 3 - ties) / 2) / 24)
    return float(r_plus), float(ndtr(-((r_plus - mn) / se)))


def _ranks(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The average ranks of x (1 for the smallest) and the sizes of its groups of tied values (those > 1)."""
    j = np.argsort(x, kind="stable")
    y = x[j]
    first = np.concatenate([[True], y[:-1] != y[1:]])
    starts = np.flatnonzero(first)
    counts = np.diff(starts, append=x.size)
    ranks = np.empty(x.size)
    ranks[j] = np.repeat(starts + 1 + (counts.astype(float) - 1) / 2, counts)
    return ranks, counts[counts > 1].astype(float)


def _exact_sf(n: int, k: int) -> float:
    """P(R⁺ ≥ k) for n differences without ties or zeros: R⁺'s distribution built one rank at a time (each
    rank is positive or not with probability ½), summed from the nearer tail as scipy does."""
    c = np.ones(1)
    for m in range(1, n + 1):
        prev = c
        c = np.zeros(m * (m + 1) // 2 + 1)
        c[:prev.size] = prev * 0.5
        c[-prev.size:] += prev * 0.5
    return float(c[k:].sum()) if k <= n * (n + 1) / 4 else float(1 - c[:k].sum())


def _sign_flip_sf(d, r, r_zero_2, observed) -> float:
    """The share of the 2ⁿ sign flips of d whose R⁺ is at least the observed one (less a relative 100 ε, as
    scipy.stats.permutation_test counts its exact test)."""
    signs = np.array(list(product((1.0, -1.0), repeat=d.size)))
    null = np.sum(((signs * d) > 0).astype(float) * r, axis=-1) + r_zero_2
    p = np.count_nonzero(null >= observed - abs(np.finfo(float).eps * 100 * observed)) / float(signs.shape[0])
    return float(np.clip(p, 0., 1.))
