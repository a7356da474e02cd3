"""fit.png's lines (issue 38): on Kim's grid of load levels 0.2 N·m apart, the τ⊥ ≈ ±0.55 line took the
points of two levels (0.4 and 0.6 N·m) and joined them into a saw-tooth. Each line is now one load level."""
import numpy as np

from cvtdesign.uses.diagnosis import _load_slices


def test_each_line_is_one_load_level():
    rng = np.random.default_rng(0)
    levels = np.round(np.arange(-1, 1.0001, 0.2), 10)
    g, lv = (a.ravel() for a in np.meshgrid(np.arange(-80, 81, 10.0), np.arange(levels.size)))
    load = levels[lv] + 0.005 * rng.standard_normal(lv.size)       # the measured loads: each level's noise
    slices = _load_slices(load, lv)
    assert [round(x, 1) for x, _ in slices] == [-1.0, -0.6, 0.6, 1.0] or \
        [round(x, 1) for x, _ in slices] == [-1.0, -0.4, 0.4, 1.0], [x for x, _ in slices]
    for _, idx in slices:
        assert len(np.unique(lv[idx])) == 1 and len(np.unique(g[idx])) == idx.size == 17


def test_random_loads_keep_the_window():
    rng = np.random.default_rng(1)
    load = rng.uniform(-1, 1, 187)
    slices = _load_slices(load, np.arange(187))
    assert len(slices) == 4 and all(np.all(np.abs(load[idx] - x) <= 0.2) for x, idx in slices)
