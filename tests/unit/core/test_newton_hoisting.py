"""The Newton iteration with what depends on the parameters alone evaluated once a solve (core.deferred's
`newton_functions`, core.newton's `hoisted`): the same iterates, to the last bit, as the iteration that evaluates
everything at every step, and as CasADi's rootfinder; and it is only taken where it pays."""
import casadi as ca
import numpy as np

from cvtdesign.core.deferred import HOIST_SHARE, DeferredCalls
from cvtdesign.core.newton import newton_solver


def _problem(heavy: bool):
    """A residual in x (3) and p (4) with a deferred call (a 'table' of one argument) whose argument depends on x
    and p: with `heavy`, the coefficients are long expressions of p alone (as a deviated geometry is)."""
    x, p = ca.SX.sym("x", 3), ca.SX.sym("p", 4)
    a = ca.SX.sym("a")
    table = ca.Function("table", [a], [ca.tanh(a) + 0.1 * a])
    table_jac = ca.Function("table_jac", [a], [table(a), ca.jacobian(table(a), a)])
    calls = DeferredCalls()
    terms = 30 if heavy else 1
    coef = [sum(ca.sin(p[i] * k + p[(i + 1) % 4]) / k for k in range(1, terms + 1)) + 3 for i in range(4)]
    v = calls.call(table, table_jac, [x[0] * coef[0] + p[1]])
    F = ca.vertcat(coef[1] * x[0] + ca.sin(x[1]) + v - p[2],
                   coef[2] * x[1] + x[0] * x[2] - coef[3] * p[3],
                   coef[3] * x[2] + ca.atan(x[0] - p[0]) - 1)
    residual = calls.close("residual", [x, p], [F])
    jacobian = calls.jacobian("residual_jac", [x, p], F, 0)
    return residual, jacobian, calls.newton_functions("residual", x, p, F)


def test_hoisted_iteration_gives_the_same_iterates_to_the_last_bit():
    """From starts near and far (the line search at work), at several parameters: the hoisted written-out
    iteration, the plain one and CasADi's `newton` rootfinder end on the same bits; the implicit derivatives
    of the differentiable one are the plain one's."""
    residual, jacobian, hoisted = _problem(heavy=True)
    assert hoisted is not None, "the p-only work is most of an iteration here: it must be taken out"
    plain = newton_solver("plain", residual, 1e-12, 1e-12, 40, jacobian=jacobian)
    lifted = newton_solver("lifted", residual, 1e-12, 1e-12, 40, jacobian=jacobian, hoisted=hoisted)
    ref = ca.rootfinder("ref", "newton", residual, {"abstol": 1e-12, "abstolStep": 1e-12, "max_iter": 40,
                                                    "error_on_fail": False})
    rng = np.random.default_rng(3)
    for x0 in ([0, 0, 0], [8, -5, 3], [-30, 2, 40]):
        for pv in rng.uniform(-1, 1, (4, 4)):
            a, b, c = (np.array(s(x0, pv)) for s in (plain, lifted, ref))
            assert np.all(np.isfinite(a))
            np.testing.assert_array_equal(b, a)
            np.testing.assert_array_equal(b, c)
    d_plain = newton_solver("d_plain", residual, 1e-12, 1e-12, 40, True, jacobian)
    d_lifted = newton_solver("d_lifted", residual, 1e-12, 1e-12, 40, True, jacobian, hoisted)
    pm = ca.MX.sym("p", 4)
    jac = [np.array(ca.Function("j", [pm], [ca.jacobian(s([0, 0, 0], pm), pm)])([0.2, -0.3, 0.5, 0.1]))
           for s in (d_plain, d_lifted)]
    assert np.abs(jac[0]).max() > 0.1
    np.testing.assert_array_equal(jac[1], jac[0])


def test_hoisting_is_left_out_where_it_takes_out_little():
    """Where what depends on p alone is under HOIST_SHARE of an iteration, the iteration stays as it is (on
    box.yaml's compare model it made a compiled point 7 % slower)."""
    assert 0 < HOIST_SHARE < 1
    assert _problem(heavy=False)[2] is None
