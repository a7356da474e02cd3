"""Calls of compiled functions that the model's SX graph defers (core.model, core.contact.laws).

The model is assembled as CasADi SX expressions, the fastest form for its many scalar operations. A function
that is a table lookup in C (the creep-force surface, core.contact.surface) cannot be written out in SX, and SX
differentiates a call to it direction by direction: the box's 24 × 24 Jacobian then evaluated the surface's
full Jacobian 192 times for 8 contacts. So such a call is deferred: the law gets an SX symbol v standing for
the call's value, and `close` builds a function of the model as three parts, an SX function of the calls'
arguments a, the calls, and an SX function of the rest with v as an input. Its Jacobian is the chain rule,
written out once in SX with the calls' Jacobians D as symbols,

    d out/d in = ∂out/∂in + ∂out/∂v · D · ∂a/∂in,

and evaluated with one call per table that returns the value and its Jacobian together: 8 table evaluations
for the box's Jacobian. It is attached to the function as its Jacobian, so every derivative CasADi takes of
it (the Newton solves, the implicit derivatives for the optimiser) uses it. Without deferred calls `close`
is the plain SX function.

A model closes several functions of the same expressions (the residual, its Jacobian in the unknowns for the
Newton solves, selections of outputs), so each derivative block, the arguments' function and each list's common
subexpressions (ca.cse, a third of a model's build) are made once a model and reused (`_derivative`, `_args`,
`_shared`): the Newton's Jacobian is a part of the residual's and takes its blocks as they are.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca


HOIST_SHARE = 1 / 3   # `newton_functions` takes out what depends on the parameters alone where that is at least
                      # this share of an iteration's operations. Measured, CPU a point compiled: box_tolerances'
                      # model (69 % of them) 335 → 200 µs; compare's model of box.yaml (10 %) 95 → 102 µs


@dataclass
class _Call:
    value_fn: ca.Function        # args → value
    jacobian_fn: ca.Function     # args → (value, ∂value/∂arg for each arg)
    args: list                   # SX expressions of the arguments
    value: ca.SX                 # the symbol standing for the value


class DeferredCalls:
    """The deferred calls of one model."""

    def __init__(self):
        self.calls: list[_Call] = []
        self._made: dict = {}        # what is made once (module docstring), by kind and the ids of what it is of
        self._held: list = []        # ... and those objects, so that their ids stay theirs

    def _once(self, key: tuple, of: tuple, make):
        """make(), made once for the objects `of` (compared by identity) and `key`."""
        key = (*key, *map(id, of))
        if key not in self._made:
            self._held.append(of)
            self._made[key] = make()
        return self._made[key]

    def _derivative(self, out, wrt):
        """ca.jacobian(out, wrt), taken once a model."""
        return self._once(("d",), (out, wrt), lambda: ca.jacobian(out, wrt))

    def _values(self):
        """The calls' value symbols stacked."""
        return self._once(("values", len(self.calls)), (), lambda: ca.vertcat(*(c.value for c in self.calls)))

    def _args(self, inputs: list) -> ca.Function:
        """Function(inputs) → every call's arguments, flat, common subexpressions shared."""
        return self._once(("args", len(self.calls)), tuple(inputs), lambda: ca.Function(
            "deferred_args", inputs, self._shared([a for c in self.calls for a in c.args])))

    def _shared(self, exprs: list) -> list:
        """ca.cse(exprs), or, where an earlier list held every one of them, their forms of then (the same nodes)."""
        if all((("cse", id(e)) in self._made) for e in exprs):
            return [self._made["cse", id(e)] for e in exprs]
        shared = ca.cse(exprs)
        for e, c in zip(exprs, shared):
            self._once(("cse",), (e,), lambda c=c: c)
        return shared

    def call(self, value_fn: ca.Function, jacobian_fn: ca.Function, args: list) -> ca.SX:
        """An SX symbol that stands for value_fn(*args) (one output) in the expressions built from it;
        jacobian_fn(*args) gives the value and its derivative with respect to each argument."""
        value = ca.SX.sym(f"{value_fn.name()}_{len(self.calls)}", value_fn.sparsity_out(0))
        self.calls.append(_Call(value_fn, jacobian_fn, list(args), value))
        return value

    def close(self, name: str, inputs: list, outputs: list) -> ca.Function:
        """Function(inputs) → outputs, the deferred calls in them evaluated, with its Jacobian by the chain rule
        (module docstring). `inputs` are the SX symbols the expressions depend on besides the calls' values."""
        values = self._values()
        if not self.calls or not ca.depends_on(ca.vertcat(*outputs), values):
            return ca.Function(name, inputs, outputs)
        args = self._args(inputs)
        rest = ca.Function(f"{name}_rest", [*inputs, values], ca.cse(outputs))
        mx_in = [ca.MX.sym(f"i{k}", s.sparsity()) for k, s in enumerate(inputs)]
        arg_values = self._split(args.call(mx_in))
        value = ca.vertcat(*(c.value_fn(*a) for c, a in zip(self.calls, arg_values)))
        jac = self._jacobian(name, inputs, outputs, mx_in)
        chained = ca.Function(name, mx_in, rest.call([*mx_in, value]),
                              {"custom_jacobian": jac, "jac_penalty": 0, "enable_forward": False,
                               "enable_reverse": False, "enable_fd": False, "never_inline": True})
        # called from a plain MX function, whose derivatives CasADi then takes through `jac` (a function with
        # only a custom Jacobian cannot build every derivative CasADi asks of it, e.g. a rootfinder's)
        return ca.Function(name, mx_in, chained.call(mx_in))

    def _split(self, flat: list) -> list[list]:
        out, k = [], 0
        for c in self.calls:
            out.append(flat[k:k + len(c.args)])
            k += len(c.args)
        return out

    def jacobian(self, name: str, inputs: list, output, wrt: int) -> ca.Function:
        """Function(inputs) → (∂output/∂inputs[wrt], output), the chain rule through the deferred calls (what a
        Newton solve needs, without the derivatives with respect to the other inputs)."""
        if not self.calls:
            return ca.Function(name, inputs, [ca.jacobian(output, inputs[wrt]), output])
        mx_in = [ca.MX.sym(f"i{k}", s.sparsity()) for k, s in enumerate(inputs)]
        jac, value = self._chain(name, inputs, [output], [inputs[wrt]], mx_in)
        return ca.Function(name, mx_in, [jac[0], value[0]])

    def _jacobian(self, name, inputs, outputs, mx_in) -> ca.Function:
        """jac_<name>: (inputs, nominal outputs) → ∂out_k/∂in_j for every output k and input j (CasADi's order:
        outputs major)."""
        result, _ = self._chain(name, inputs, outputs, inputs, mx_in)
        nominal = [ca.MX.sym(f"o{k}", out.sparsity()) for k, out in enumerate(outputs)]
        names_in = [f"i{k}" for k in range(len(inputs))] + [f"out_o{k}" for k in range(len(outputs))]
        names_out = [f"jac_o{k}_i{j}" for k in range(len(outputs)) for j in range(len(inputs))]
        return ca.Function(f"jac_{name}", [*mx_in, *nominal], result, names_in, names_out)

    def _chain(self, name, inputs, outputs, wrt, mx_in) -> tuple[list, list]:
        """(∂out_k/∂w_j for outputs k and w_j in `wrt`, outputs-major; the outputs' values) as MX of mx_in, by
        the chain rule: the partial derivatives in SX (sparse), the calls' Jacobians D from one evaluation
        each, and the products ∂out/∂v · D · ∂a/∂w as sparse matrix products."""
        values = self._values()
        live, a_all = self._live(inputs)
        partial = [self._derivative(out, w) for out in outputs for w in wrt]
        through = [self._derivative(out, values) for out in outputs] + [self._derivative(a_all, w) for w in wrt]
        parts = ca.Function(f"{name}_partials", [*inputs, values], self._shared(partial + through + list(outputs)))
        value, D = self._evaluated(self._split(self._args(inputs).call(mx_in)), live)
        got = parts.call([*mx_in, value])
        n_p, n_o = len(partial), len(outputs)
        direct, by_value, of_args = got[:n_p], got[n_p:n_p + n_o], got[n_p + n_o:n_p + n_o + len(wrt)]
        result = [direct[k * len(wrt) + j] + ca.mtimes(ca.mtimes(by_value[k], D), of_args[j])
                  for k in range(n_o) for j in range(len(wrt))]
        return result, got[n_p + n_o + len(wrt):]

    def newton_functions(self, name: str, x: ca.SX, p: ca.SX, output: ca.SX) -> tuple[ca.Function, ...] | None:
        """What a Newton iteration in x at fixed p evaluates, with every expression of p alone taken out of it
        and evaluated once a solve (CasADi's `extract_parametric`): (parametric: p → q = [p; those values],
        residual: (x, q) → output, jacobian: (x, q) → (∂output/∂x, output)). For a point of the tolerance
        study the deviated geometry, the contacts' Hertz constants and the creep-force surface's arguments that
        follow from them are such expressions: they were recomputed at every iteration and line-search trial.
        The operations are the same ones, so are the numbers. Neither function is differentiable in q (the
        loop that calls them is not: core.newton). None where that takes out less than HOIST_SHARE of an
        iteration's operations."""
        values = self._values()
        live, a_all = self._live([x, p])
        arg_list = [a for c in self.calls for a in c.args]
        blocks = [self._derivative(output, x)]
        if self.calls:
            blocks += [self._derivative(output, values), self._derivative(a_all, x)]
        # the shared forms the arguments' and the Jacobian's functions have (an expression there twice would get
        # two symbols, and stay twice); extract_parametric keeps their sharing
        merged = self._shared(arg_list) + self._shared([*blocks, output])
        got, symbols, expressions = ca.extract_parametric(merged, p)
        q = ca.vertcat(p, *symbols)
        if (ca.Function("after", [x, q, values], got).n_instructions()
                > (1 - HOIST_SHARE) * ca.Function("before", [x, p, values], merged).n_instructions()):
            return None
        parametric = ca.Function(f"{name}_parametric", [p], [ca.vertcat(p, *ca.cse(expressions))])
        n = len(arg_list)
        partial, through, out = got[n], got[n + 1:-1], got[-1]
        if not self.calls:
            jac = ca.Function(f"{name}_jac", [x, q], [partial, out])
            return parametric, ca.Function(f"{name}_res", [x, q], [out]), jac
        xm, qm = ca.MX.sym("x", x.sparsity()), ca.MX.sym("q", q.sparsity())
        arg_values = self._split(ca.Function(f"{name}_args", [x, q], got[:n]).call([xm, qm]))
        rest = ca.Function(f"{name}_rest", [x, q, values], [out])
        residual = ca.Function(f"{name}_res", [xm, qm], rest.call(
            [xm, qm, ca.vertcat(*(c.value_fn(*a) for c, a in zip(self.calls, arg_values)))]))
        parts = ca.Function(f"{name}_parts", [x, q, values], [partial, *through, out])
        value, D = self._evaluated(arg_values, live)
        J, by_value, of_args, F = parts.call([xm, qm, value])
        return parametric, residual, ca.Function(f"{name}_jac", [xm, qm], [J + ca.mtimes(ca.mtimes(by_value, D), of_args), F])

    def _live(self, inputs: list) -> tuple[list, ca.SX]:
        """Which of each call's arguments depend on the inputs (constant ones have no D), and those arguments
        stacked."""
        def make():
            every = ca.vertcat(*inputs)
            live = [[ca.depends_on(a, every) for a in c.args] for c in self.calls]
            return live, ca.vertcat(*(a for c, lv in zip(self.calls, live) for a, on in zip(c.args, lv) if on))
        return self._once(("live", len(self.calls)), tuple(inputs), make)

    def _evaluated(self, arg_values: list, live: list) -> tuple[ca.MX, ca.MX]:
        """The calls at their arguments' values, each once with its Jacobian: (their values stacked, D the
        block-diagonal matrix of their derivatives in their `live` arguments)."""
        value_list, blocks = [], []
        for c, a, lv in zip(self.calls, arg_values, live):
            v, *d = c.jacobian_fn(*a)
            value_list.append(v)
            blocks.append(ca.horzcat(*(dk for dk, on in zip(d, lv) if on)))
        return ca.vertcat(*value_list), ca.diagcat(*blocks)
