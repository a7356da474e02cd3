"""CasADi's Newton rootfinder (with its line search) written out as a graph that can be compiled to C.

CasADi's `newton` rootfinder cannot be code-generated. Its `fast_newton` can, but it always takes the full
step, so where the line search matters it ends elsewhere: on existing.yaml's envelope it turns 3 of
the 4 points that do not converge into gross slip. `newton_solver` builds the iteration of `newton`
(casadi/solvers/newton.cpp, CasADi 3.6–3.8) from plain CasADi nodes, so the compiled model gives the same
numbers as the interpreted one (tests/unit/core/test_compiled.py). One iteration:
 1. F and its Jacobian J at x; stop if ‖F‖∞ ≤ abstol;
 2. dx = J⁻¹F by sparse Householder QR; stop if ‖dx‖∞ ≤ abstol_step;
 3. α = 1, ½, ¼, …: take x − α dx at the first α with ‖F(x − α dx)‖∞ ≤ (1 − α/2)‖F(x)‖∞; stop with x
    unchanged once α‖dx‖∞ ≤ abstol_step;
at most max_iter iterations. Norms skip NaN entries, as `newton`'s do. The one difference: step 3 tries at
most LINE_SEARCH_STEPS values of α. So a step longer than 2^LINE_SEARCH_STEPS · abstol_step, or one that is
not finite (a singular J), ends the iteration with x unchanged, where `newton` halves on (down to α = 0, which
gives NaN for a step that is not finite).

The loop's own operations are not differentiated. Where derivatives are wanted, one more Newton step is taken
from its result x*, x = x* − J(x*)⁻¹F(x*, p), with J held constant: at a root F = 0, so the value is x* (to
the solver's tolerance), and the derivative is −J⁻¹ ∂F/∂p, the implicit function theorem's, as the `newton`
rootfinder gives it. (CasADi's `fast_newton` rootfinder with no iterations did this before; it cannot be
code-generated once the residual calls an external function, as the creep-force surface is.)
"""
from __future__ import annotations

import casadi as ca

LINE_SEARCH_STEPS = 80      # step lengths α = 1, ½, … tried at most in one line search


def newton_solver(name: str, residual: ca.Function, abstol: float, abstol_step: float, max_iter: int,
                  derivatives: bool = False, jacobian: ca.Function | None = None,
                  hoisted: tuple | None = None) -> ca.Function:
    """(x0, p) → x with residual(x, p) = 0, by CasADi's `newton` rootfinder's iteration (module docstring);
    with `derivatives`, x is differentiable in p by the implicit function theorem.

    `residual` is a Function (x, p) → F, F the size of x: SX, or MX where it calls compiled functions
    (core.deferred), and then `jacobian` (x, p) → (∂F/∂x, F) is given. `hoisted` (core.deferred's
    `newton_functions`: p → q, and the residual and its Jacobian as functions of (x, q)) has the iteration
    evaluate what depends on p alone once, not at every iteration: the same numbers."""
    x, p = residual.sx_in() if residual.is_a("SXFunction") else residual.mx_in()
    F = residual(x, p)
    jac = jacobian or ca.Function(f"{name}_jac", [x, p], [ca.jacobian(F, x), F])
    res = ca.Function(f"{name}_res", [x, p], [F])
    parametric, res_q, jac_q = hoisted or (None, res, jac)
    m = res_q.size1_in(1)
    search = _line_search(name, res_q, x.numel(), m, abstol_step)
    iteration = _iteration(name, jac_q, res_q, search, x.numel(), m, abstol, abstol_step)
    x0, qm, pm = ca.MX.sym("x0", x.sparsity()), ca.MX.sym("q", m), ca.MX.sym("p", p.sparsity())
    loop = ca.Function(f"{name}_loop", [x0, qm], [iteration.fold(max_iter)(ca.vertcat(x0, 1), qm)[:x.numel()]],
                       {"is_diff_in": [False, False], "is_diff_out": [False]})
    root = loop(x0, parametric(pm) if parametric else pm)
    if derivatives:
        held = ca.Function(f"{name}_held_jac", [x, p], [jac(x, p)[0]],
                           {"is_diff_in": [False, False], "is_diff_out": [False]})
        root = root - _qr_solve(name, held.sparsity_out(0))(held(root, pm), res(root, pm))
    return ca.Function(name, [x0, pm], [root], ["x0", "p"], ["x"])


def _iteration(name, jac, res, search, n, m, abstol, abstol_step) -> ca.Function:
    """(z = [x; running], p) → z after one iteration (unchanged once running is 0). Each branch is a
    Function of its own with the intermediates as inputs, so a switch evaluates only the branch it takes,
    and nothing twice."""
    z, p, x, dx = ca.MX.sym("z", n + 1), ca.MX.sym("p", m), ca.MX.sym("x", n), ca.MX.sym("dx", n)
    r, s = ca.MX.sym("r"), ca.MX.sym("s")
    J, F = jac(z[:n], p)
    Jm, Fm = ca.MX.sym("J", J.sparsity()), ca.MX.sym("F", n)

    def stop(*inputs):
        return ca.Function(f"{name}_stop", [x, *inputs, p], [ca.vertcat(x, 0)])
    # the full step where it decreases ‖F‖∞ enough, else the line search (a switch's index 0 is its first case)
    full = ca.Function(f"{name}_full", [x, dx, r, s, p], [ca.vertcat(x - dx, 1)])
    move = ca.Function.conditional(f"{name}_move", [search], full)
    step = ca.Function(f"{name}_step", [x, dx, r, s, p],
                       [move(ca.norm_inf(res(x - dx, p)) <= 0.5 * r, x, dx, r, s, p)])
    # the Newton step, unless it is shorter than abstol_step
    short = ca.Function.conditional(f"{name}_short", [step], stop(dx, r, s))
    d = _qr_solve(name, J.sparsity())(Jm, Fm)
    update = ca.Function(f"{name}_update", [x, Jm, Fm, r, p],
                         [short(ca.norm_inf(d) <= abstol_step, x, d, r, ca.norm_inf(d), p)])
    # unless converged
    converged = ca.Function.conditional(f"{name}_converged", [update], stop(Jm, Fm, r))
    going = ca.Function(f"{name}_going", [z, p], [converged(ca.norm_inf(F) <= abstol, z[:n], J, F, ca.norm_inf(F), p)])
    iterate = ca.Function.conditional(f"{name}_iterate", [ca.Function(f"{name}_idle", [z, p], [z])], going)
    return ca.Function(f"{name}_iteration", [z, p], [iterate(z[n], z, p)])


def _qr_solve(name, sparsity: ca.Sparsity) -> ca.Function:
    """(J, F) → J⁻¹F by sparse Householder QR with an approximate-minimum-degree column order (CasADi's
    `qr` linear solver), unrolled for J's sparsity into plain arithmetic: the same numbers without the
    index loops, 2–3× faster compiled."""
    J, F = ca.SX.sym("J", sparsity), ca.SX.sym("F", sparsity.size1())
    V, R, beta, prinv, pc = ca.qr_sparse(J, True)
    return ca.Function(f"{name}_qr", [J, F], [ca.qr_solve(F, V, R, beta, prinv, pc)])


def _line_search(name, res, n, m, abstol_step) -> ca.Function:
    """(x, dx, r = ‖F(x)‖∞, s = ‖dx‖∞, p) → [x_next; running], after the full step failed: α = ½, ¼, …
    until ‖F(x − α dx)‖∞ ≤ (1 − α/2) r (x_next = x − α dx, running 1) or α s ≤ abstol_step (x, 0)."""
    x, dx, r, s, p = ca.MX.sym("x", n), ca.MX.sym("dx", n), ca.MX.sym("r"), ca.MX.sym("s"), ca.MX.sym("p", m)
    state = ca.MX.sym("state", n + 3)         # [α; searching; x_next; running]
    alpha = state[0]
    xt = x - alpha * dx
    found = ca.vertcat(alpha, 0, xt, 1)
    failed = ca.vertcat(alpha, 0, x, 0)
    halved = ca.vertcat(alpha / 2, 1, state[2:])
    trial = ca.Function(f"{name}_trial", [state, x, dx, r, s, p], [
        ca.if_else(ca.norm_inf(res(xt, p)) <= (1 - alpha / 2) * r, found,
                   ca.if_else(alpha * s <= abstol_step, failed, halved))])
    wait = ca.Function(f"{name}_wait", [state, x, dx, r, s, p], [state])
    once = ca.Function.conditional(f"{name}_once", [wait], trial)
    halving = ca.Function(f"{name}_halving", [state, x, dx, r, s, p], [once(state[1], state, x, dx, r, s, p)])
    out = halving.fold(LINE_SEARCH_STEPS - 1)(ca.vertcat(0.5, 1, x, 0), x, dx, r, s, p)
    # still searching after the last α: give up as at abstol_step
    return ca.Function(f"{name}_search", [x, dx, r, s, p], [ca.if_else(out[1], ca.vertcat(x, 0), out[2:])])
