"""The diagnosis's significance tests (diagnose.significance), written with numpy and scipy.special so that a
`cvtdesign diagnose` run does not import scipy.stats (issue 35), give what scipy.stats gives: the χ² survival
function, the one-way ANOVA and the one-sided Wilcoxon signed-rank test with zeros split, on random data with
ties and zeros, at every size where scipy changes method (sign flips up to 13 differences with ties or zeros,
the exact distribution up to 50 without, the normal approximation beyond)."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import Phase, given, settings
from hypothesis import strategies as st
from scipy import stats

from cvtdesign.diagnosis.diagnose import significance

TOL = 1e-12
PROPERTY = settings(max_examples=300, deadline=None, derandomize=True, database=None,
                    phases=(Phase.explicit, Phase.generate))

# values on a coarse grid make ties and zeros common; a continuous part makes tie-free samples too
GRID = st.integers(-6, 6).map(float)
FREE = st.floats(-50, 50, allow_nan=False, allow_infinity=False, allow_subnormal=False)
VALUES = st.one_of(GRID, FREE)


def close(a, b):
    return (np.isnan(a) and np.isnan(b)) or a == b or abs(a - b) <= TOL * max(1.0, abs(b))


WILCOXON_SAMPLES = st.one_of(st.lists(GRID, min_size=1, max_size=13), st.lists(FREE, min_size=1, max_size=60),
                             st.lists(VALUES, min_size=1, max_size=200))


def check_wilcoxon(values):
    d = np.array(values)
    if np.all(d == 0):
        return                                  # σ = 0: scipy divides by zero; the diagnosis never asks (p = 1)
    r, p = significance.wilcoxon_greater(d)
    ref = stats.wilcoxon(d, alternative="greater", zero_method="zsplit")
    assert close(r, float(ref.statistic)) and close(p, float(ref.pvalue)), (r, p, ref)


@settings(PROPERTY, max_examples=100)
@given(st.one_of(st.lists(FREE, min_size=1, max_size=60), st.lists(VALUES, min_size=14, max_size=200)))
def test_wilcoxon_greater_is_scipys(values):
    """The exact and the normal methods; the sign flips of up to 13 tied values are checked on one sample here
    (test_wilcoxon_greater_each_method) and on many with the slow tests: scipy's own permutation test takes
    about a second a sample."""
    check_wilcoxon(values)


@pytest.mark.slow
@PROPERTY
@given(WILCOXON_SAMPLES)
def test_wilcoxon_greater_is_scipys_on_many_samples(values):
    check_wilcoxon(values)


@pytest.mark.parametrize("d", [np.arange(1.0, 11.0) - 3.5,                      # 10, no ties: exact
                               np.array([0.0, 0, 1, -1, 2, 2, 3, -3, 4, 5, 6]),  # 11, zeros and ties: sign flips
                               np.r_[np.zeros(3), np.arange(1.0, 30.0)],          # 32 with zeros: normal
                               np.linspace(-1, 3, 51)])                          # 51: normal
def test_wilcoxon_greater_each_method(d):
    """One sample of each of scipy's methods, so a failure names the method."""
    r, p = significance.wilcoxon_greater(d)
    ref = stats.wilcoxon(d, alternative="greater", zero_method="zsplit")
    assert close(r, float(ref.statistic)) and close(p, float(ref.pvalue)) and 0 < p < 1


@PROPERTY
@given(st.lists(st.lists(VALUES, min_size=1, max_size=25), min_size=2, max_size=8))
def test_f_oneway_is_scipys(groups):
    samples = [np.array(g) for g in groups]
    f, p = significance.f_oneway(*samples)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")         # scipy warns where it returns NaN (all samples of one value)
        ref = stats.f_oneway(*samples)
    assert close(f, float(ref.statistic)) and close(p, float(ref.pvalue)), (f, p, ref)


@PROPERTY
@given(st.floats(0, 1e4, allow_nan=False), st.integers(1, 2000))
def test_chi2_sf_is_scipys(stat, dof):
    assert close(significance.chi2_sf(stat, dof), float(stats.chi2.sf(stat, dof)))
