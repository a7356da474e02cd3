"""Where the gap lies, in the data's own space: the operating points' neighbours in (γ, τ⊥[, ω1]), whatever
the protocol (a grid, random points, one load).

Coordinates are the commanded γ and the τ⊥ of each point's load level (`load_coordinate`: the measured τ⊥
for random loads) scaled by the variant's envelope (its γ and load ranges: physical scales, so a load held at
one value stays one value and its noise does not pull neighbours apart),
and log ω1 scaled by its own spread when the motor speed varies by more than 5 %. On Kim's grid the graph is
the grid's: each point joined to its γ and load neighbours.

* `Neighbours.edges`: each point joined to its GRAPH_K nearest (both ways). The gap is "structured" when the
  residual field is autocorrelated over these edges (Moran-type statistic, z > AUTO_Z: p < 0.001), which does
  not depend on the noise estimate; the mean product of neighbouring residuals is the power of the gap's
  smooth part (noise has none).
* `Neighbours.loo`: a local quadratic fit over each point's FIT_K nearest, leaving the point out: what the
  neighbours say the point should be. Its deviation is the noise plus what the smooth fit misses, so its
  robust scale is the noise where the gap is smooth at the scale of the neighbours, and an upper bound
  elsewhere.
* regions: connected groups (over the edges) of at least two points whose α residual is beyond REGION_Z σ,
  one sign, described by the γ and τ⊥ their points span.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from cvtdesign.core.layout import Layout
from cvtdesign.diagnosis.measured import Measured

AUTO_Z = 3.1           # spatial autocorrelation z above which a residual field is structured (p < 0.001)
REGION_Z = 3.0         # operating points whose mean residual is beyond this many σ form the gap's regions
GRAPH_K = 4            # each point's nearest neighbours joined by an edge (in 2 coordinates; 6 in 3)
SPEED_SPREAD = np.log(1.05)   # log ω1 is a coordinate when it spans more than this (5 %)
FLAT = 0.05            # a coordinate spanning less than this share of its scale is left out (one load)
ASPECTS = (1 / 8, 1 / 4, 1 / 2, 1.0, 2.0)   # load scales tried for the local fits (local_fits)


@dataclass
class Neighbours:
    """The operating points' neighbourhoods: scaled coordinates (n, d), the graph's edges (m, 2) with i < j,
    and for local fits each point's nearest (n, K) with the fit's pseudo-inverse (n, q, K) and the
    leverage h of the left-out point (n,)."""
    coords: np.ndarray
    scales: np.ndarray       # physical unit per coordinate: [deg, N m, 1] (the envelope's ranges)
    names: list
    edges: np.ndarray
    near: np.ndarray
    pinv: np.ndarray
    leverage: np.ndarray

    def loo(self, values: np.ndarray) -> np.ndarray:
        """Standardised leave-one-out deviations (v_i − fit_i)/√(1 + h_i): for white noise of σ, σ each."""
        return (np.asarray(values, float) - self.smooth(values)) / np.sqrt(1 + self.leverage)

    def smooth(self, values: np.ndarray) -> np.ndarray:
        """What each point's neighbours say it should be: the local fits' values at the points."""
        v = np.asarray(values, float)
        return np.einsum("nk,nk->n", self.pinv[:, 0, :], v[self.near])


def coordinates(data: Measured, layout: Layout, aspect: float = 1.0) -> tuple[np.ndarray, np.ndarray, list]:
    """(scaled coordinates, their scales, names) of the operating points (module docstring); `aspect`
    shrinks the load's scale (a smaller one brings the points at other loads closer)."""
    r = data.rows
    cols = {"gamma_deg": (r["gamma_cmd_deg"].to_numpy(), float(np.ptp(np.degrees(layout.gamma_grid))) or 1.0, 1.0),
            "tau_perp_Nm": (load_coordinate(data), float(np.ptp(layout.load_grid)) or 1.0, aspect)}
    w = np.log(np.abs(r["omega_1"].to_numpy()))
    if np.ptp(w) > SPEED_SPREAD:
        cols["log_omega_1"] = (w, float(np.ptp(w)), 1.0)
    keep = {k: c for k, c in cols.items() if np.ptp(np.percentile(c[0], [2, 98])) > FLAT * c[1]}
    keep = keep or {"gamma_deg": cols["gamma_deg"]}
    return (np.column_stack([v * a / s for v, s, a in keep.values()]), np.array([s / a for _, s, a in keep.values()]),
            list(keep))


def load_coordinate(data: Measured) -> np.ndarray:
    """Each operating point's τ⊥ [N m] as a coordinate: its load level's mean (measured._group), which is the
    measured τ⊥ itself where each point is a level of its own (random loads). On a grid of a few load levels
    the measured loads of one level differ by their noise only; as a coordinate, a local fit over neighbours
    at one level read that noise as a load slope, and took the part of the residuals that the load's noise
    carries for a smooth gap (the noise came out a third low on five load levels)."""
    r = data.rows
    if data.load_levels is None or "load_bin" not in r.columns:
        return r["tau_perp"].to_numpy()
    return np.asarray(data.load_levels, float)[r["load_bin"].to_numpy()]


def neighbours(data: Measured, layout: Layout, aspect: float = 1.0) -> Neighbours:
    """The neighbourhoods of the operating points of `data` (replicates merged), with the load's scale
    shrunk by `aspect` (coordinates)."""
    x, scales, names = coordinates(data, layout, aspect)
    n, d = x.shape
    x = x + 1e-9 * np.arange(n)[:, None] / max(n, 1)     # equal points (repeated commands) stay distinct
    # points split by the direction they were approached from (sequence.py) neighbour only their own kind
    apart = data.rows["approach"].to_numpy()[:, None] * 1e3 if "approach" in data.rows.columns else np.zeros((n, 0))
    tree = cKDTree(np.hstack([x, apart]))
    k = min(GRAPH_K if d <= 2 else 6, n - 1)
    _, idx = tree.query(tree.data, k + 1)
    pairs = np.sort(np.column_stack([np.repeat(np.arange(n), k), idx[:, 1:].ravel()]), axis=1)
    edges = np.unique(pairs, axis=0)
    q = 1 + d + d * (d + 1) // 2                        # quadratic terms
    kf = min(2 * q, n - 1)
    _, near = tree.query(tree.data, kf + 1)
    near = near[:, 1:]
    pinv, lev = _local_fits(x, near, q)
    return Neighbours(x, scales, names, edges, near, pinv, lev)


def local_fits(data: Measured, layout: Layout, resid: dict) -> dict[str, Neighbours]:
    """For each channel of a residual field, the neighbourhoods whose local fits follow it best: of the load
    scales ASPECTS, the one with the least robust leave-one-out deviation (median |loo|). A creep-like gap is
    nearly linear in the load and bends with γ, so its neighbours are best taken at nearly the same γ; a gap
    that bends with the load calls for the opposite, and the data choose."""
    tried = [neighbours(data, layout, a) for a in ASPECTS]
    return {c: min(tried, key=lambda nb: float(np.nanmedian(np.abs(nb.loo(v))))) for c, v in resid.items()}


def _local_fits(x: np.ndarray, near: np.ndarray, q: int) -> tuple[np.ndarray, np.ndarray]:
    """Per point, the pseudo-inverse (q, K) of the quadratic design of its neighbours centred on it (row 0
    gives the value at the point, rows 1..d its gradient), and the leverage of predicting there."""
    n, d = x.shape
    dx = x[near] - x[:, None, :]                                  # (n, K, d)
    terms = [np.ones(dx.shape[:2])] + [dx[..., j] for j in range(d)]
    terms += [dx[..., a] * dx[..., b] for a in range(d) for b in range(a, d)]
    X = np.stack(terms[:q], axis=-1)                              # (n, K, q)
    pinv = np.linalg.pinv(X, rcond=1e-8)                          # (n, q, K)
    lev = np.einsum("nqk,nqk->n", pinv[:, :1, :], pinv[:, :1, :])  # e0ᵀ(XᵀX)⁺e0
    return pinv, lev


def _edge_products(nb: Neighbours, v: np.ndarray) -> np.ndarray:
    a, b = v[nb.edges[:, 0]], v[nb.edges[:, 1]]
    m = np.isfinite(a) & np.isfinite(b)
    return (a * b)[m]


def autocorrelation_z(nb: Neighbours, z: np.ndarray) -> float:
    """Lag-1 spatial autocorrelation of a residual field (one channel, points) over the neighbour edges, as
    a z-statistic: ≈ N(0, 1) for white residuals, large for a smooth structured gap."""
    v = np.asarray(z, float) - np.nanmean(z)
    prods = _edge_products(nb, v)
    var = np.nanmean(v ** 2)
    if prods.size < 4 or not var > 0:
        return 0.0
    return float(prods.mean() / var * np.sqrt(prods.size))


def neighbour_pairs(nb: Neighbours, ok: np.ndarray) -> int:
    """Neighbouring pairs of points where both are `ok`."""
    return int(np.sum(ok[nb.edges[:, 0]] & ok[nb.edges[:, 1]]))


def structured_power(nb: Neighbours, z: np.ndarray) -> np.ndarray:
    """Power of the smooth (structured) part of a residual field (channels, points), per channel: the mean
    product of neighbouring points' residuals. Independent noise has zero expected product, so this
    estimates the gap's power whatever the noise level. Points that are NaN are left out."""
    out = []
    for zc in np.atleast_2d(z):
        prods = _edge_products(nb, np.asarray(zc, float))
        out.append(float(prods.mean()) if prods.size else 0.0)
    return np.array(out)


@dataclass
class Region:
    """A connected group of operating points where the α gap stands out, one sign."""
    gamma_deg: list            # [min, max] commanded γ of its points [deg]
    load_Nm: list              # [min, max] τ⊥ of its points [N m]
    mean_residual_deg: float   # mean α residual over its points [deg]
    points: int
    members: np.ndarray        # indices of its operating points

    def to_json(self) -> dict:
        return {"gamma_deg": self.gamma_deg, "load_Nm": self.load_Nm, "mean_residual_deg": self.mean_residual_deg,
                "points": self.points}


def regions(data: Measured, nb: Neighbours, resid_alpha: np.ndarray, noise_alpha: np.ndarray) -> list[Region]:
    """Where the α gap stands out: points whose residual exceeds REGION_Z standard errors, joined over the
    neighbour edges into same-sign groups of at least two points, largest |mean residual|·size first."""
    r = data.rows
    z = np.nan_to_num(resid_alpha / noise_alpha)
    out = []
    for sign in (1, -1):
        flag = sign * z > REGION_Z
        e = nb.edges[flag[nb.edges[:, 0]] & flag[nb.edges[:, 1]]]
        n = len(z)
        graph = coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n))
        _, label = connected_components(graph, directed=False)
        for lab in np.unique(label[flag]):
            members = np.flatnonzero(flag & (label == lab))
            if members.size < 2:
                continue
            g, t = r["gamma_cmd_deg"].to_numpy()[members], r["tau_perp"].to_numpy()[members]
            out.append(Region([float(g.min()), float(g.max())], [float(t.min()), float(t.max())],
                              float(np.mean(resid_alpha[members])), int(members.size), members))
    out.sort(key=lambda reg: -abs(reg.mean_residual_deg) * reg.points)
    return out


def in_regions(n: int, regs: list[Region]) -> np.ndarray:
    """Mask of the operating points in any of `regs`."""
    m = np.zeros(n, bool)
    for reg in regs:
        m[reg.members] = True
    return m
