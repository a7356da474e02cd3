"""The independent simulator's solver (independent_sim.py): a damped Newton iteration over many operating
points at once, in numpy alone (nothing of cvtdesign's model)."""
from __future__ import annotations

import numpy as np


def newton(prob, x, tol=1e-11, max_iter=40):
    """Damped Newton on all points at once: x (n, P), prob.residual(x) (n, P); a finite-difference Jacobian per
    point, backtracking per point. Returns (x, converged (P,))."""
    n, P = x.shape
    r = prob.residual(x)
    nrm = np.max(np.abs(r), axis=0)
    done = nrm < tol
    for _ in range(max_iter):
        if done.all():
            break
        act = ~done
        J = np.empty((P, n, n))
        h = 1e-7 * (1 + np.abs(x))
        for j in range(n):
            xp = x.copy()
            xp[j] += h[j]
            J[:, :, j] = ((prob.residual(xp) - r) / h[j]).T
        try:
            dx = np.linalg.solve(J[act], -r.T[act][..., None])[..., 0].T
        except np.linalg.LinAlgError:
            dx = np.stack([np.linalg.lstsq(J[i], -r[:, i], rcond=None)[0] for i in np.flatnonzero(act)], axis=1)
        step = np.zeros_like(x)
        step[:, act] = dx
        lam = np.ones(P)
        for _ in range(12):                          # backtracking per point
            xn = x + lam * step
            rn = prob.residual(xn)
            nn = np.max(np.abs(rn), axis=0)
            bad = act & ~(nn < nrm * (1 - 1e-4 * lam)) & np.isfinite(nrm)
            bad |= act & ~np.isfinite(nn)
            if not bad.any():
                break
            lam = np.where(bad, lam / 2, lam)
        ok = np.isfinite(nn)
        x = np.where(ok, xn, x)
        r = np.where(ok, rn, r)
        nrm = np.where(ok, nn, nrm)
        done = nrm < tol
    return x, done
