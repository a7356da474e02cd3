"""Quantities with units in variant and study files → SI floats (DESIGN.md sec. 1).

A field may hold a plain number (already SI), a string with units ("40 mm", "0.0049 1/N", "10 deg"), or an
expression "= asin(d / (2*R))" over the file's named parameters (evaluated in SI, angles in rad). Pint
does the unit parsing; the expression evaluator accepts only arithmetic, parameter names and a few math
functions, so a file can never run code.
"""
from __future__ import annotations

import ast
import difflib
import functools
import operator

import casadi as ca


class InputError(ValueError):
    """Bad user input: the message is one line naming the file, the field or row, and what was expected."""


def suggest(word: str, options) -> str:
    """' (did you mean 'x'?)' for the option nearest to a misspelt word, or ''."""
    close = difflib.get_close_matches(word, list(options), n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ""


@functools.cache
def registry():
    import pint

    try:  # pint caches its parsed definitions on disk: 0.05 s instead of 0.2 s per start
        return pint.UnitRegistry(cache_folder=":auto:")
    except OSError:
        return pint.UnitRegistry()


# SI unit of each kind of quantity, and an example for error messages
KINDS = {
    "length": ("m", "'40 mm'"),
    "force": ("N", "'100 N'"),
    "compliance": ("1/N", "'0.0038 1/N'"),
    "stiffness": ("N/m", "'2e5 N/m'"),
    "pressure": ("Pa", "'25 MPa'"),
    "angle": ("rad", "'10 deg'"),
    "torque": ("N*m", "'1 N*m'"),
    "speed": ("rad/s", "'10 rad/s'"),
    "dimensionless": ("", "'0.8'"),
}

_BINOPS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
           ast.Pow: operator.pow}
_FUNCS = {f: getattr(ca, f) for f in ("sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sqrt", "exp", "log")}
_CONSTS = {"pi": 3.141592653589793}


def evaluate_expression(text: str, names: dict, where: str):
    """Evaluate '= expr' over `names` (SI values, floats or CasADi symbols)."""
    def ev(node):
        if isinstance(node, ast.Expression):
            return ev(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
            return float(node.value)
        if isinstance(node, ast.BinOp) and type(node.op) in _BINOPS:
            return _BINOPS[type(node.op)](ev(node.left), ev(node.right))
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            return -ev(node.operand) if isinstance(node.op, ast.USub) else ev(node.operand)
        if isinstance(node, ast.Name):
            if node.id in names:
                return names[node.id]
            if node.id in _CONSTS:
                return _CONSTS[node.id]
            raise InputError(f"{where}: unknown name '{node.id}' in expression (parameters: {', '.join(names) or 'none'})")
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in _FUNCS and not node.keywords:
            return _FUNCS[node.func.id](*[ev(a) for a in node.args])
        raise InputError(f"{where}: unsupported expression '{text}' (arithmetic, parameter names and "
                         f"{', '.join(_FUNCS)} only)")
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError:
        raise InputError(f"{where}: cannot parse expression '{text}'") from None
    return ev(tree)


def to_si(raw, kind: str, where: str, names: dict | None = None):
    """Convert a file value to SI for a quantity of `kind` (see KINDS). Plain numbers are taken as SI."""
    unit, example = KINDS[kind]
    if isinstance(raw, bool) or raw is None:
        raise InputError(f"{where}: expected a {kind} like {example}, got {raw!r}")
    if isinstance(raw, (int, float)):
        return float(raw)
    if not isinstance(raw, str):
        return raw  # already a number-like (e.g. a CasADi symbol substituted by a study)
    text = raw.strip()
    if text.startswith("="):
        return evaluate_expression(text[1:].strip(), names or {}, where)
    import pint

    try:
        q = registry().Quantity(text)
        return float(q.to(unit).magnitude) if unit else float(q.to("dimensionless").magnitude)
    except (pint.errors.DimensionalityError, pint.errors.UndefinedUnitError, ValueError, TypeError,
            AttributeError, AssertionError):
        raise InputError(f"{where}: expected a {kind} like {example}, got '{raw}'") from None
