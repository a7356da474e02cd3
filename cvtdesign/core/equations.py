"""The model's equations at one operating point (core.model compiles them): the unknowns (the sphere's
angular velocity, the output shaft's and the idlers' speeds, every contact's two tangential forces), each
contact's creep law with the effects' terms, the sphere's force balance on its compliant mounts (the normal
forces) and moment balance, the idlers' torque balance, the shaft torques, and each contact's outputs
(creepages, patch, coefficients, losses, fork torques). Kim et al., "Causes of microslip in a continuously
variable transmission", eqs 19-32, generalised to any layout; units SI.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from cvtdesign.core.effects import EFFECTS, NEUTRAL, SWITCH, ContactState, smooth_abs
from cvtdesign.core.geometry import roller_pose
from cvtdesign.core.kinematics import vec
from cvtdesign.core.layout import Layout

F_SCALE = 10.0        # [N] force scaling of the unknowns


class Hooks:
    """The hooks of the effects that are on, with their parameter symbols, in the vocabulary's order.

    An effect whose switch ('effect:on', core.effects.SWITCH) is among the names can be switched off: while
    its switch is 0 its hooks leave the value as it was (`transform`) or give the hook's NEUTRAL term
    (`collect`), so one model holds several effect sets (the diagnosis's candidates) with each set's own
    numbers: the switch selects (CasADi's if_else), it never scales, and an exact zero added or a one
    multiplied changes no value. (The Newton solves' linear algebra, ordered by the Jacobian's sparsity, which
    the switched terms widen, can differ in round-off: 1e-12 of α, 1e-9 of the scaled unknowns.)"""

    def __init__(self, effects, theta, names):
        ordered = [e for e in EFFECTS if e in effects]
        self.items = [(EFFECTS[e], {p: theta[names.index(f"{e}.{p}")] for p in EFFECTS[e].params},
                       theta[names.index(e + SWITCH)] if e + SWITCH in names else None) for e in ordered]

    def transform(self, hook, value, *context):
        """value ← f(*context, value, p) for every effect with that hook."""
        for eff, p, on in self.items:
            if hook in eff.hooks:
                value = _switched(on, eff.hooks[hook](*context, value, p), value)
        return value

    def collect(self, hook, *context) -> list:
        return [_switched(on, eff.hooks[hook](*context, p), NEUTRAL[hook]) for eff, p, on in self.items
                if hook in eff.hooks]


def _switched(on, value, otherwise):
    """`value` where the switch `on` is 1, `otherwise` where it is 0 (element by element for tuples); `value`
    itself for an effect that is always on (on is None)."""
    if on is None:
        return value
    if isinstance(value, tuple):
        return tuple(ca.if_else(on, v, o) for v, o in zip(value, otherwise))
    return ca.if_else(on, value, otherwise)


@dataclass
class Unknowns:
    x: ca.SX
    Om: object
    w2: object
    w_idle: dict
    Ft: object
    Fa: object
    v_ref: object
    om_ref: object


def unknowns(layout: Layout, w1) -> Unknowns:
    """The unknowns, scaled: Ω by the ideal sphere speed, ω2 and idler speeds by ω1, forces by F_SCALE."""
    rollers = layout.rollers
    idlers = [r for r in rollers if r.role == "steering"]
    nc, ni = len(rollers), len(idlers)
    primary = next(r for r in rollers if r.role == "drive" and r.shaft == 1)
    v_ref = w1 * primary.radius                      # [m/s] speed scale
    om_ref = v_ref / layout.sphere_radius            # [rad/s] sphere speed scale
    x = ca.SX.sym("x", 4 + ni + 2 * nc)
    return Unknowns(x, om_ref * x[0:3], w1 * x[3], {r.name: w1 * x[4 + j] for j, r in enumerate(idlers)},
                     F_SCALE * x[4 + ni: 4 + ni + nc], F_SCALE * x[4 + ni + nc:], v_ref, om_ref)


def normal_forces(layout: Layout, poses, Fvec):
    """Sphere force balance on preloaded compliant mounts: K δ = Σ (F_i − P_i n_i), N_i = P_i + k_i n_i·δ."""
    rollers = layout.rollers
    K = sum(r.stiffness * ca.mtimes(n, n.T) for r, (n, _) in zip(rollers, poses))
    rhs = sum(Fvec[i] - rollers[i].preload * poses[i][0] for i in range(len(rollers)))
    delta = ca.solve(K, rhs)
    return [r.preload + r.stiffness * ca.dot(n, delta) for r, (n, _) in zip(rollers, poses)]


def equations(layout: Layout, hooks: Hooks, law, const, u: Unknowns, w1, phi, calls, fork_rate=None):
    """Every contact's creep law, the sphere's moment balance, the idlers' torque balance and the shaft
    torques, with the effects' terms. Returns (slip rows, moment, idler rows, shaft torques, per-contact
    outputs, saturation utilisations).

    `fork_rate` [rad/s], the steering angle's rate (the dynamic model, core.dynamics; None: the steady model's
    forks at rest): a fork turning at ω_f = ρ φ̇ f moves its roller's contact point at R ω_f × n and pivots
    it at ω_f·n, so each contact sees the sphere's angular velocity relative to its fork, Ω − ω_f, in its slip,
    rolling speed and spin."""
    R = layout.sphere_radius
    poses = [roller_pose(r, phi) for r in layout.rollers]
    tdirs = [ca.cross(n, a) for n, a in poses]
    Fvec = [u.Ft[i] * tdirs[i] + u.Fa[i] * poses[i][1] for i in range(len(poses))]
    N = normal_forces(layout, poses, Fvec)
    slip, moment, idle, tau, sat = [], ca.SX.zeros(3), [], {1: 0, 2: 0}, []
    per = {k: [] for k in ("xi", "eta", "spin", "utilisation", "mu", "M_spin", "loss", "a", "b", "G", "C11", "C22",
                           "C23", "roll_sign", "T_fork", "fork_pivot", "fork_slide", "V", "slide", "force_per_row")}
    for i, r in enumerate(layout.rollers):
        (n, a), t, c = poses[i], tdirs[i], const[i]
        drive = r.role != "steering"
        r_eff = hooks.transform("rolling_radius", r.radius, r)
        w_i = r.ratio * (w1 if r.shaft == 1 else u.w2) if drive else u.w_idle[r.name]
        om = u.Om if fork_rate is None or r.fork_axis is None else u.Om - r.fork_ratio * fork_rate * vec(r.fork_axis)
        s = R * ca.cross(om, n) - r_eff * w_i * t
        s_t, s_a = ca.dot(s, t), ca.dot(s, a)
        roll, spin = ca.dot(om, a), ca.dot(om, n)
        V = smooth_abs(R * roll, 1e-9 * u.v_ref)                          # rolling speed [m/s]
        N_creep, n_exp = law.creep_normal(hooks, r, N[i])
        eps = c["eps0"] * (c["n_ref"] / N_creep) ** n_exp if "eps0" in c else None
        state = ContactState(r, drive, V, spin, 1e-9 * u.om_ref, 1e-6 * u.om_ref, roll, N[i], N_creep, eps, c["b"],
                             hooks.transform("friction", c["mu"]), u.Ft[i], u.Fa[i], c)
        law_rows = law.rows(layout, hooks, state, s_t, s_a, u.v_ref, calls)
        slip += law_rows.rows
        sat += law_rows.utilisation
        m_spin = law_rows.spin_moment
        M = sum(hooks.collect("resistance", state))
        on_sphere = R * ca.cross(n, Fvec[i]) - M * a + m_spin * n      # the contact's moment about the centre
        moment += on_sphere
        if drive:
            tau[r.shaft] = tau[r.shaft] + r.ratio * (r_eff * u.Ft[i] - M)
        else:
            idle.append((-r_eff * u.Ft[i] + M) / (r.radius * F_SCALE))
        per["xi"].append(s_t / law_rows.speed)
        per["eta"].append(s_a / law_rows.speed)
        per["spin"].append(spin / law_rows.speed)
        per["mu"].append(state.mu)
        per["V"].append(V)
        per["slide"].append(ca.sqrt(s_t ** 2 + s_a ** 2 + (c["a"] * spin) ** 2 + (1e-9 * u.v_ref) ** 2))  # [m/s]
        per["force_per_row"].append(law_rows.force_per_row)
        per["M_spin"].append(m_spin)
        for k, v in zip(("T_fork", "fork_pivot", "fork_slide"), fork_terms(r, n, a, on_sphere, R)):
            per[k].append(v)
        per["loss"].append(-(u.Ft[i] * s_t + u.Fa[i] * s_a + m_spin * spin) - M * (w_i - roll))
        size = (ca.fmax(N[i], 0) / r.preload) ** (1.0 / 3.0)
        per["a"].append(c["a"] * size)
        per["b"].append(c["b"] * size)
        per["G"].append(c["G"])
        per["roll_sign"].append(ca.if_else(roll >= 0, 1.0, -1.0))   # the patch frame's σ (core.contact.laws)
        gab = c["G"] * c["a"] * c["b"] * size ** 2
        per["C11"].append(law_rows.slopes[0] / gab)
        per["C22"].append(law_rows.slopes[1] / gab)
        per["C23"].append(law_rows.slopes[2] / (gab * ca.sqrt(gab / c["G"])))
        per["utilisation"].append(ca.sqrt(u.Ft[i] ** 2 + u.Fa[i] ** 2 + 1e-6) / (state.mu * N[i]))  # 1 mN smoothing
    per["N"] = N
    return slip, moment, idle, tau, per, sat


def fork_terms(roller, n, a, on_sphere, R):
    """A forked roller's steering terms (0, 0, 0 for a roller on no fork), f its fork axis through the centre:

    - T_fork [N m], the torque the steering actuator applies about f to hold the fork while the contact
      rolls: f·M_c, M_c the contact's moment on the sphere about the centre (R n × F − M a + M_spin n). The
      roller in equilibrium passes M_c to its fork (its axle carries none about a: the idler's balance), and
      the fork's bearings none about f.
    - fork_pivot [-] = f·n and fork_slide [m] = R (f × n)·a: per unit fork rate, the patch's pivoting rate
      and its slide across the roller (the part along the rolling direction the free roller takes up), from
      which core.steering finds the torque at standstill.

    Brokowski et al. ("Toward improved CVTs: theoretical and experimental results", 6.2.2): smaller contact
    patches reduce steering effort."""
    if roller.fork_axis is None:
        return ca.SX(0), ca.SX(0), ca.SX(0)
    f = vec(roller.fork_axis)
    return ca.dot(f, on_sphere), ca.dot(f, n), R * ca.dot(ca.cross(f, n), a)
