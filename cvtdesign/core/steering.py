"""Steering effort: the torque that turns each fork and the steering motor's torque through the linkage.

Brokowski et al. ("Toward improved CVTs: theoretical and experimental results", 6.2.2) note that smaller
contact patches reduce steering effort; for a cobot this torque sizes the steering actuator. Two cases:

* **Rolling** (the model's outputs `T_fork` and `steering_torque`, core.equations.fork_terms): the torque that
  holds fork i while its contact rolls, T_i = f_i·M_c, M_c the contact's moment on the sphere about the
  centre (the lateral force's lever R n × F, the spin moment about n, the rolling resistance). Through the
  linkage, where fork i turns by k_i times the steering angle φ (k_i its gear ratio, fork_ratio), virtual work gives the
  motor's torque T = Σ k_i T_i.
* **At standstill** (this module): turning a fork with the sphere at rest slides its whole patch. Per unit
  fork rate the patch pivots at f·n and slides across the roller at R (f × n)·a (the roller, free on its
  axle, takes up the part along its rolling direction), so Coulomb friction at the Hertz pressure resists
  with μN·L, L = (1/N) ∫ p |v| dA (sliding_lever): μNℓ for a fork through its contact (pure pivoting, ℓ
  core.contact.hertz.pivot_lever), μN|s| for a pure slide. Every fork resists whichever way it turns, so
  the motor needs Σ |k_i| μ N_i L_i. It is taken at each operating point's normal forces (a loaded machine
  held still and resteered).
"""
from __future__ import annotations

import casadi as ca
import numpy as np

NODES = 32            # sliding_lever's Gauss–Legendre nodes in u by default (4 × as many in t)
CHUNK_NODES = 2 ** 16      # quadrature nodes sliding_lever evaluates at once (a block of patches: 0.5 MB an array)


def sliding_lever(a, b, pivot, slide, nodes: int = NODES):
    """(1/N) ∫ p |v| dA [m] for a Hertz patch sliding rigidly with the velocity field v(x, y) = (−ω y, s + ω x),
    ω = `pivot` [-] about the normal and s = `slide` [m] across it, per unit rate: the power a fully sliding
    patch dissipates over μN, so μN·sliding_lever is the torque that drives the motion. Pure pivoting gives
    ℓ|ω| (core.contact.hertz.pivot_lever), pure sliding |s|.

    Quadrature with x = a sin u cos t, y = b sin u sin t, so p dA / N = (3/2π) cos²u sin u du dt: Gauss–Legendre
    in u (`nodes` points) and the trapezoid rule in t (4·`nodes`, exact for the periodic integrand's
    harmonics). It converges spectrally unless the slide's instantaneous centre lies inside the patch, where
    |v| has a kink (K. L. Johnson, Contact Mechanics, 1985, sec. 4.2 for the pressure). |v| is even in y, so the
    nodes at t and 2π − t are one node of twice the weight (_nodes: half the work). Every patch is evaluated at
    once, in blocks of CHUNK_NODES nodes, with |v|² formed from its two components.

    Parameters
    ----------
    a, b : contact semi-axes [m]; pivot [-], slide [m]: arrays broadcast together

    Returns
    -------
    array of the broadcast shape [m]
    """
    a, b, w, s = np.broadcast_arrays(*(np.asarray(v, float) for v in (a, b, pivot, slide)))
    xh, yh, weight = (q.ravel() for q in _nodes(nodes))
    out = np.full(a.shape, np.nan)
    held = np.isfinite(a) & np.isfinite(b)
    a, b, w, s = (q[held] for q in (a, b, w, s))
    got = np.empty(a.size)
    step = max(1, CHUNK_NODES // xh.size)            # patches a block, whose arrays stay in the CPU's cache
    for i in range(0, a.size, step):
        j = slice(i, i + step)
        vv = np.multiply.outer((w[j] * b[j]) ** 2, yh * yh)    # |v|² at every node of every patch of the block,
        vx = np.multiply.outer(w[j] * a[j], xh)                # in place
        vx += s[j, None]
        vx *= vx
        vv += vx
        got[j] = np.sqrt(vv, out=vv) @ weight
    out[held] = got
    return out


def sliding_lever_expr(a, b, pivot, slide, nodes: int = 12):
    """sliding_lever as a CasADi expression (one contact), for an optimisation's rows: the same quadrature on
    fewer nodes (12: 1e-15 relative for pure pivoting, 1e-6 where the slide's centre lies outside the patch, as
    on the box's forks, 3e-4 where it lies inside), |v| smoothed by 1e-12 m so that its derivative exists
    everywhere."""
    xh, yh, weight = _nodes(nodes)
    x, y = a * ca.DM(xh.ravel()), b * ca.DM(yh.ravel())
    return ca.dot(ca.DM(weight.ravel()), ca.sqrt((pivot * y) ** 2 + (slide + pivot * x) ** 2 + 1e-24))


def _nodes(nodes: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The quadrature's points on the unit disc (x̂ = sin u cos t, ŷ = sin u sin t) and weights (p dA / N): the
    trapezoid rule's 4·`nodes` angles t = 2πk/(4·nodes) folded onto 0 ≤ t ≤ π, for integrands even in ŷ (the
    nodes at t and 2π − t one node of twice the weight; t = 0 and π are their own mirror)."""
    u, wu = np.polynomial.legendre.leggauss(nodes)
    u, wu = np.pi / 4 * (u + 1), np.pi / 4 * wu
    t = np.linspace(0.0, np.pi, 2 * nodes + 1)
    fold = np.where((t > 0) & (t < np.pi), 2.0, 1.0)
    rho = np.sin(u)[:, None]
    weight = (wu * np.cos(u) ** 2 * np.sin(u))[:, None] * 3 / (4 * nodes) * fold   # (3/2π)(2π/4n)
    return rho * np.cos(t), rho * np.sin(t), weight


INPUTS = ("N", "a", "b", "mu", "fork_pivot", "fork_slide")   # the model outputs the standstill torques are made of


def standstill_slope(at: dict, along: dict, fork_ratios, h: float) -> np.ndarray:
    """The derivative of the steering motor's standstill torque (points) along a direction in which the INPUTS
    move: `at` their values and `along` their derivatives (each contacts × points, from the model's exact
    derivatives), carried through the quadrature by a central difference of step h in the direction's unit."""
    up, down = ({k: at[k] + sign * h * along[k] for k in INPUTS} for sign in (1, -1))
    return (standstill_torques(up, fork_ratios)[1] - standstill_torques(down, fork_ratios)[1]) / (2 * h)


def standstill_torques(res: dict, fork_ratios, nodes: int = NODES) -> tuple[np.ndarray, np.ndarray]:
    """The torque [N m] to turn each fork at standstill (contacts × points, 0 for a roller on no fork) and the
    steering motor's, Σ |k_i| T_i (points), from an envelope result (core.metrics.envelope): the normal
    forces N, patches a, b, friction μ and the forks' `fork_pivot` and `fork_slide` of each point (sliding_lever
    on `nodes`)."""
    k = np.abs(np.asarray(fork_ratios, float)).reshape(-1, *([1] * (np.ndim(res["N"]) - 1)))
    forked = np.broadcast_to(k > 0, np.shape(res["N"]))
    lever = np.zeros(np.shape(res["N"]))
    lever[forked] = sliding_lever(res["a"][forked], res["b"][forked], res["fork_pivot"][forked],
                                  res["fork_slide"][forked], nodes)
    per_fork = res["mu"] * np.maximum(res["N"], 0.0) * lever
    return per_fork, np.sum(k * per_fork, axis=0)


SAMPLE_NODES = 12     # sliding_lever's nodes for samples' envelopes (core.metrics.envelopes): within 3e-4 of the
                      # default 32 where a slide's centre lies inside the patch, 1e-6 outside it, 1e-15 for pure
                      # pivoting (sliding_lever_expr); on the shipped variants' samples 3e-15 (7 × less work)
