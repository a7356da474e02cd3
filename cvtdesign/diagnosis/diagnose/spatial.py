"""Where the gap lies: per operating point the mean α residual and its z; cells beyond REGION_Z σ form
regions (connected on the γ × load grid, one sign); the gap is "structured" when the residual field is
spatially autocorrelated (Moran-type lag-1 statistic over γ and load neighbours, z > AUTO_Z: p < 0.001),
which does not depend on the noise estimate."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from cvtdesign.diagnosis.measured import Measured

AUTO_Z = 3.1           # spatial autocorrelation z above which a residual field is structured (p < 0.001)
REGION_Z = 3.0         # operating points whose mean residual is beyond this many σ form the gap's regions


@dataclass
class Region:
    """A connected same-sign region of the γ × load grid where the α gap stands out."""
    gamma_deg: list            # [min, max] commanded γ [deg]
    load_Nm: list              # [min, max] load level τ⊥ [N m]
    mean_residual_deg: float   # mean α residual over its cells [deg]
    points: int                # grid cells
    cells: np.ndarray          # (points, 2) indices into (gamma_levels, load_levels)

    def to_json(self) -> dict:
        return {"gamma_deg": self.gamma_deg, "load_Nm": self.load_Nm, "mean_residual_deg": self.mean_residual_deg,
                "points": self.points}


def autocorrelation_z(data: Measured, z: np.ndarray) -> float:
    """Lag-1 spatial autocorrelation of the per-point mean z over the γ × load grid (neighbours in γ and
    in load), as a z-statistic: ≈ N(0, 1) for white residuals, large for a smooth structured gap."""
    grid = point_grid(data, z)
    v = grid - np.nanmean(grid)
    prods = []
    for a, b in ((v[1:, :], v[:-1, :]), (v[:, 1:], v[:, :-1])):
        m = np.isfinite(a) & np.isfinite(b)
        prods.append((a * b)[m])
    prods = np.concatenate(prods)
    var = np.nanmean(v ** 2)
    if prods.size < 4 or not var > 0:
        return 0.0
    rho = prods.mean() / var
    return float(rho * np.sqrt(prods.size))


def neighbour_pairs(data: Measured, ok: np.ndarray) -> int:
    """Neighbouring pairs of points (γ or load neighbours on the grid) where both are `ok`."""
    grid = np.isfinite(point_grid(data, np.where(ok, 0.0, np.nan)))
    return int((grid[1:, :] & grid[:-1, :]).sum() + (grid[:, 1:] & grid[:, :-1]).sum())


def structured_power(data: Measured, z: np.ndarray) -> float:
    """Power of the smooth (structured) part of a residual field (channels, points) in z units: the sum over
    the channels of the mean product of neighbouring points' residuals on the γ × load grid. Independent
    noise has zero expected product, so this estimates the gap's power whatever the noise level, and a
    wrong noise scale cancels in a ratio of two powers. Points that are NaN are left out."""
    total = 0.0
    for zc in z:
        grid = point_grid(data, zc)
        prods = [(a * b)[np.isfinite(a) & np.isfinite(b)] for a, b in
                 ((grid[1:, :], grid[:-1, :]), (grid[:, 1:], grid[:, :-1]))]
        prods = np.concatenate(prods)
        total += float(prods.mean()) if prods.size else 0.0
    return total


def point_grid(data: Measured, values: np.ndarray, reduce=np.nanmean) -> np.ndarray:
    """Per-row values → (γ level, load level) grid of their mean over replicates and speed levels (NaN where
    no point, or no finite value)."""
    r = data.rows
    grid = np.full((len(data.gamma_levels), len(data.load_levels)), np.nan)
    for (i, j), idx in r.groupby(["gamma_bin", "load_bin"]).indices.items():
        v = values[idx]
        if np.isfinite(v).any():
            grid[i, j] = reduce(v)
    return grid


def regions(data: Measured, resid_alpha: np.ndarray, noise_alpha: np.ndarray) -> list[Region]:
    """Where the α gap stands out: operating points whose mean residual exceeds REGION_Z standard errors,
    grouped into connected same-sign regions of the γ × load grid, largest |mean residual|·size first."""
    mean = point_grid(data, resid_alpha)
    count = point_grid(data, np.ones_like(resid_alpha), np.nansum)
    se = point_grid(data, noise_alpha) / np.sqrt(np.maximum(count, 1))
    z = mean / se
    out = []
    for sign in (1, -1):
        mask = np.nan_to_num(sign * z) > REGION_Z
        lab, n = ndimage.label(mask)
        for k in range(1, n + 1):
            cells = np.argwhere(lab == k)
            g = data.gamma_levels[cells[:, 0]]
            t = data.load_levels[cells[:, 1]]
            vals = mean[lab == k]
            out.append(Region([float(g.min()), float(g.max())], [float(t.min()), float(t.max())],
                              float(np.mean(vals)), int(len(cells)), cells))
    out.sort(key=lambda r: -abs(r.mean_residual_deg) * r.points)
    return out


def in_regions(data: Measured, regs) -> np.ndarray:
    r = data.rows
    m = np.zeros(len(r), bool)
    for reg in regs:
        cells = {tuple(c) for c in reg.cells}
        m |= np.array([(a, b) in cells for a, b in zip(r["gamma_bin"], r["load_bin"])])
    return m


def structure(data: Measured, z: np.ndarray) -> float:
    """The largest spatial-autocorrelation z over the channels of a residual field (channels, points)."""
    return max(autocorrelation_z(data, zc) for zc in z)
