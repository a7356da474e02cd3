"""Deferred calls (core.deferred): the functions a model closes over the same expressions give the numbers of the
expressions written out in SX, and what they share is made once a model (the arguments' function, the
derivative blocks, the common subexpressions: the Newton's Jacobian is a part of the residual's)."""
from __future__ import annotations

import casadi as ca
import numpy as np

from cvtdesign.core import deferred
from cvtdesign.core.deferred import DeferredCalls


def table():
    """A stand-in for a compiled table: f(z, r) = (sin z0 · r, z1² + z0 z1) with its Jacobian, as MX functions."""
    z, r = ca.MX.sym("z", 2), ca.MX.sym("r")
    value = ca.vertcat(ca.sin(z[0]) * r, z[1] ** 2 + z[0] * z[1])
    f = ca.Function("table", [z, r], [value])
    return f, ca.Function("table_jac", [z, r], [value, ca.jacobian(value, z), ca.jacobian(value, r)]), \
        ca.Function("table_sx", [z, r], [value]).expand()


def closed_model(calls: DeferredCalls):
    """A residual and an output of unknowns x (2) and parameters p (2) through two deferred calls of the table,
    and the same in plain SX."""
    f, f_jac, f_sx = table()
    x, p = ca.SX.sym("x", 2), ca.SX.sym("p", 2)
    args = [[ca.vertcat(x[0] * p[0], x[1]), p[1]], [ca.vertcat(x[1] + p[0], x[0] * x[1]), 2.0]]
    v = [calls.call(f, f_jac, a) for a in args]
    plain = [f_sx(*a) for a in args]
    resid = lambda v: ca.vertcat(v[0][0] + x[0] - p[1], v[1][1] * p[0] + x[1] ** 3 + v[0][1])   # noqa: E731
    output = lambda v: ca.vertcat(v[0][0] * v[1][0], x[0] + v[1][1])                              # noqa: E731
    return x, p, resid(v), output(v), resid(plain), output(plain)


def test_closed_functions_and_jacobians_are_the_plain_expressions():
    """The residual, its Jacobian in x (jacobian) and in (x, p) (close's, through CasADi), and an output's Jacobian,
    against the same expressions in plain SX, at a few points."""
    calls = DeferredCalls()
    x, p, resid, output, resid_sx, output_sx = closed_model(calls)
    G = calls.close("residual", [x, p], [resid])
    G_x = calls.jacobian("residual_jac", [x, p], resid, 0)
    out = calls.close("out", [x, p], [output])
    X, P = ca.MX.sym("X", 2), ca.MX.sym("P", 2)
    got = ca.Function("got", [X, P], [G(X, P), ca.jacobian(G(X, P), ca.vertcat(X, P)), *G_x(X, P),
                                      ca.jacobian(out(X, P), ca.vertcat(X, P))])
    want = ca.Function("want", [x, p], [resid_sx, ca.jacobian(resid_sx, ca.vertcat(x, p)), ca.jacobian(resid_sx, x),
                                        resid_sx, ca.jacobian(output_sx, ca.vertcat(x, p))])
    rng = np.random.default_rng(1)
    for _ in range(4):
        at = rng.normal(size=2), rng.normal(size=2)
        for g, w in zip(got(*at), want(*at)):
            np.testing.assert_allclose(np.asarray(g), np.asarray(w), rtol=1e-13, atol=1e-13)


def test_what_the_closes_share_is_made_once(monkeypatch):
    """Closing the residual, its Jacobian in x and an output: the calls' arguments are made into one function, each
    derivative block is taken once, and the Newton's Jacobian needs no common-subexpression pass of its own (its
    blocks are the residual's)."""
    passes, blocks = [], []
    real_cse, real_jacobian = ca.cse, ca.jacobian
    monkeypatch.setattr(deferred.ca, "cse", lambda e: passes.append(len(e) if isinstance(e, list) else 1)
                        or real_cse(e))
    calls = DeferredCalls()
    x, p, resid, output, *_ = closed_model(calls)
    monkeypatch.setattr(deferred.ca, "jacobian", lambda e, w: blocks.append((str(e), str(w))) or real_jacobian(e, w))
    calls.close("residual", [x, p], [resid])
    after_residual = len(passes)
    calls.jacobian("residual_jac", [x, p], resid, 0)
    assert len(passes) == after_residual            # the Jacobian in x: no pass of its own
    calls.close("out", [x, p], [output])
    n_args = sum(len(c.args) for c in calls.calls)
    assert passes.count(n_args) == 1                # the arguments' function: once
    assert len(blocks) == len(set(blocks))          # each derivative block: once


def test_without_calls_close_is_the_plain_function():
    """No deferred call: close and jacobian are the plain SX functions."""
    calls = DeferredCalls()
    x, p = ca.SX.sym("x", 2), ca.SX.sym("p", 2)
    r = ca.vertcat(x[0] * p[0], ca.sin(x[1]) + p[1])
    G, G_x = calls.close("r", [x, p], [r]), calls.jacobian("r_jac", [x, p], r, 0)
    assert not calls.calls and G.is_a("SXFunction")
    np.testing.assert_allclose(np.asarray(G_x([1.0, 2.0], [3.0, 4.0])[0]), [[3.0, 0.0], [0.0, np.cos(2.0)]], rtol=1e-15)
