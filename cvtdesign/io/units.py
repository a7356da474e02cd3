"""Quantities with units in variant and study files → SI floats (SI inside the code; docs/conventions.md).

A field may hold a plain number (already SI), a string with units ("40 mm", "0.0049 1/N", "10 deg"), or an
expression "= asin(d / (2*R))" over the file's named parameters (evaluated in SI, angles in rad). Pint
does the unit arithmetic; the evaluator accepts only arithmetic, parameter names and a few math functions,
so a file can never run code.

A quantity must be of its field's kind, with the angle counted as a dimension of its own (`dimension`): pint
holds the radian dimensionless, which read 'step: 10 %' as 0.1 rad (5.73°), 'friction: 45 deg' as 0.785 and
'motor_speed: 10 Hz' as 10 rad/s (it is 62.8). An angle field takes angle units only (deg, rad, turn, ...)
or a plain number (rad); a plain-number field takes no angle unit; a speed takes an angle per time (rad/s,
rpm), never a bare rate ('Hz', '1/s').

Every value is checked, one InputError line each: a quantity is a number followed by a unit (pint parses
only the unit, and only a unit without numeric powers beyond a single digit, so no text can make it
compute a huge integer); the number, the converted value and an expression's result must be finite
(`.inf`, `nan`, `= 1/0`, `= 10**400` are refused); booleans are not numbers. `check_range` refuses values
that are not plausible for this machine, and says which unit a plain number probably meant.
"""
from __future__ import annotations

import ast
import functools
import importlib
import math
import operator
import re
import sys

import casadi as ca
import numpy as np

from cvtdesign.errors import InputError, shorten


def _import_pint():
    """pint, loaded without Dask. pint 0.25 imports dask.base when Dask is installed, only to recognise Dask
    arrays, and no quantity here is one (hgrecco/pint#2265; lazy in later pint). So Dask is hidden while pint
    loads (a None entry in sys.modules makes its import fail), which keeps it out of the commands that do not
    use it: 0.1 s of each start. In a process that has imported Dask already, pint loads as usual."""
    hide = "dask" not in sys.modules
    if hide:
        sys.modules["dask"] = None
    try:
        return importlib.import_module("pint")
    finally:
        if hide:
            del sys.modules["dask"]


pint = _import_pint()

MAX_QUANTITY_TEXT = 100    # characters of a quantity or expression string


@functools.cache
def registry():
    try:  # pint caches its parsed definitions on disk, which makes every later start faster
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
    # the materials' ageing and the duty cycle (cvtdesign life)
    "temperature": ("K", "'25 degC'"),
    "time": ("s", "'60 s'"),
    "density": ("kg/m**3", "'1100 kg/m**3'"),
    "specific_heat": ("J/(kg*K)", "'1800 J/(kg*K)'"),
    "conductivity": ("W/(m*K)", "'0.2 W/(m*K)'"),
    "wear_coefficient": ("m**3/J", "'5e-14 m**3/J'"),
    # the dynamic model (cvtdesign transient)
    "inertia": ("kg*m**2", "'2e-3 kg*m**2'"),
    "frequency": ("Hz", "'20 Hz'"),
}
# units a kind also takes besides its SI unit's dimension: a creep constant is a slip ratio (drive) or a slip
# angle (steering) per newton
ALSO = {"compliance": ("rad/N",)}


class Parameters(dict):
    """A variant's named parameters, name → SI value, with `written`: name → (the text, its pint
    dimensionality) of those written with a unit. A field that takes a parameter by a bare reference
    ('radius: = r_drive') must be of its kind: with only SI numbers left, 'preload: 100 mm' would have made
    every preload 0.1 N."""

    def __init__(self):
        super().__init__()
        self.written: dict = {}

    def record(self, name: str, text) -> None:
        """Remember the dimensionality of parameter `name` as written (a quantity with a unit, or a bare
        reference to another parameter); plain numbers and expressions have none to check."""
        if str(text).strip().startswith("="):
            other = str(text).strip()[1:].strip()
            if other in self.written:
                self.written[name] = self.written[other]
        elif not is_plain_number(text) and dimension_of(text) is not None:
            self.written[name] = (str(text).strip(), dimension_of(text))


def _check_reference(name: str, kind: str, a_kind: str, example: str, names, where: str) -> None:
    """A field of `kind` (a KINDS key; `a_kind` 'a length') written as a bare parameter reference ('= r_drive')
    takes that parameter only if it was written as a quantity of the field's kind (Parameters)."""
    written = getattr(names, "written", {}).get(name)
    if written is not None and written[1] not in dimensions(kind):
        raise InputError(f"{where}: '= {name}' is parameter {name} = '{shorten(written[0])}', not {a_kind}; "
                         f"expected {a_kind} like {example}")


# ------------------------------------------------------------------------------------------ quantities

_NUMBER = re.compile(r"\s*(?P<num>[-+]?(?:(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?|inf(?:inity)?|nan))"
                     r"(?P<unit>.*)", re.IGNORECASE | re.DOTALL)
_UNIT_CHARS = re.compile(r"[\sA-Za-zµμΩ°%_*/·()]*")
_EXPONENT = r"(?:\*\*|\^)\s*\(?\s*[-+]?\s*\d\s*\)?"          # a power of one digit: m**2, s^-1, m**(-1)


def parse_quantity(text: str):
    """'40 mm' → (40.0, the pint Unit), '45' → (45.0, None). None when the text is not a number followed by
    a unit made of unit names, '*', '/', '·', parentheses and one-digit powers (pint would otherwise evaluate
    numbers and powers in the unit, e.g. 'm**10**10**10', without bound)."""
    m = _NUMBER.fullmatch(text)
    if not m:
        return None
    value, unit = float(m["num"]), m["unit"].strip()
    if not unit:
        return value, None
    if re.search(_EXPONENT + r"\s*(?:\*\*|\^)", unit):          # a power of a power
        return None
    rest = re.sub(_EXPONENT, "", unit)
    rest = re.sub(r"^1\s*/", "/", rest)                        # '1/N'
    if not _UNIT_CHARS.fullmatch(rest) or "**" in rest or "^" in rest:
        return None
    try:
        return value, registry().parse_units(unit)
    except (pint.errors.UndefinedUnitError, pint.errors.DefinitionSyntaxError, ValueError, TypeError,
            AttributeError, AssertionError, KeyError, SyntaxError):
        return None


def is_plain_number(raw) -> bool:
    """A value written without units: a YAML number or a string holding only a number."""
    if isinstance(raw, bool):
        return False
    if isinstance(raw, (int, float)):
        return True
    if isinstance(raw, str):
        q = parse_quantity(raw.strip()) if len(raw) <= MAX_QUANTITY_TEXT else None
        return q is not None and q[1] is None
    return False


def dimension(unit):
    """The pint dimensionality of a unit (a pint Unit or its text) with the angle as a dimension of its own,
    '[angle]' to the power of the radian in the unit: deg → [angle], rpm → [angle]/[time], % and m/m → {}
    (dimensionless), Hz → 1/[time]. Pint alone holds the radian dimensionless (module docstring)."""
    reg = registry()
    unit = reg.parse_units(unit) if isinstance(unit, str) else unit
    power = dict(reg.Quantity(1, unit).to_root_units().unit_items()).get("radian", 0)
    return unit.dimensionality * pint.util.UnitsContainer({"[angle]": power}) if power else unit.dimensionality


def dimensions(kind: str) -> list:
    """The dimensions (`dimension`) a quantity of `kind` (a KINDS key) may have: its SI unit's and ALSO's."""
    return [dimension(u) for u in (KINDS[kind][0], *ALSO.get(kind, ()))]


def dimension_of(raw):
    """The dimensionality (`dimension`: the angle counted) of a file value ({} for a plain number: SI of an
    unstated kind; None for an expression or an unreadable value)."""
    if isinstance(raw, bool) or raw is None:
        return None
    if isinstance(raw, (int, float)):
        return dimension("")
    text = str(raw).strip()
    if text.startswith("=") or len(text) > MAX_QUANTITY_TEXT:
        return None
    q = parse_quantity(text)
    if q is None:
        return None
    return dimension(q[1] or "")


def kind_name(dim) -> str:
    """'a length', 'an angle', ... for a `dimension`, 'a plain number' for none, else its text ('[mass]')."""
    if dim is None:
        return "an expression"
    if not dim:
        return "a plain number"
    for kind in KINDS:
        if dim in dimensions(kind):
            return f"{'an' if kind[0] in 'aeiou' else 'a'} {kind}"
    names = {"[mass]": "a mass", "[time]": "a time", "[temperature]": "a temperature", "[current]": "a current"}
    return names.get(str(dim), f"a quantity of dimension {dim}")


def _kind_hint(kind: str, a_kind: str, dim) -> str:
    """Why a unit of the dimension `dim` is not of `kind` (`a_kind`: 'a length'), where the angle is why."""
    if kind == "angle":
        return " (a percentage or a ratio is not an angle)" if not dim else f" ({kind_name(dim)} is not an angle)"
    if kind == "speed" and "[angle]" not in dim:
        return " (a rate without an angle is not a speed: 1 Hz is 6.28 rad/s; write rad/s or rpm)"
    if "[angle]" in dim:
        return f" ({'an angle' if dim == dimension('rad') else 'a unit with an angle'} is not {a_kind})"
    return ""


# ------------------------------------------------------------------------------------------ expressions

_BINOPS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
           ast.Pow: operator.pow}
_FUNCS = {f: getattr(ca, f) for f in ("sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sqrt", "exp", "log")}
_ARITY = {f: 2 if f == "atan2" else 1 for f in _FUNCS}
_CONSTS = {"pi": 3.141592653589793}
MAX_DEPTH = 40             # nesting of an expression


def evaluate_expression(text: str, names: dict, where: str):
    """Evaluate '= expr' over `names` (SI values, floats or CasADi symbols). Every numeric intermediate
    result must be a finite real number: division by zero, overflow (|x| > 1.8e308), a complex power or a
    function outside its domain (sqrt(-1), log(0)) is one InputError line."""
    shown = shorten(text)

    def fail(why):
        return InputError(f"{where}: expression '= {shown}' {why}; expected a finite number")

    def ev(node, depth):
        if depth > MAX_DEPTH:
            raise InputError(f"{where}: expression '= {shown}' is nested more than {MAX_DEPTH} deep")
        v = _ev(node, depth + 1)
        if isinstance(v, complex):
            raise fail("has a complex result (a negative number to a fractional power)")
        if isinstance(v, float) and not math.isfinite(v):
            raise fail(f"gives {v}")
        return v

    def _ev(node, depth):
        if isinstance(node, ast.Expression):
            return ev(node.body, depth)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
            return float(node.value)
        if isinstance(node, ast.BinOp) and type(node.op) in _BINOPS:
            a, b = ev(node.left, depth), ev(node.right, depth)
            try:
                return _BINOPS[type(node.op)](a, b)
            except ZeroDivisionError:
                raise fail("divides by zero") from None
            except OverflowError:
                raise fail("overflows (beyond ±1.8e308)") from None
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            return -ev(node.operand, depth) if isinstance(node.op, ast.USub) else ev(node.operand, depth)
        if isinstance(node, ast.Name):
            if node.id in names:
                return names[node.id]
            if node.id in _CONSTS:
                return _CONSTS[node.id]
            raise InputError(f"{where}: unknown name '{shorten(node.id)}' in expression (the parameters this "
                             f"field can use: {', '.join(names) or 'none'})")
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in _FUNCS
                and not node.keywords and len(node.args) == _ARITY[node.func.id]):
            args = [ev(a, depth) for a in node.args]
            try:
                return _FUNCS[node.func.id](*args)
            except (OverflowError, ValueError, ZeroDivisionError):
                raise fail(f"is outside the domain of {node.func.id}") from None
        raise InputError(f"{where}: unsupported expression '= {shown}' (arithmetic, parameter names and "
                         f"{', '.join(_FUNCS)} only)")

    if len(text) > MAX_QUANTITY_TEXT:
        raise InputError(f"{where}: expression '= {shown}' is longer than {MAX_QUANTITY_TEXT} characters")
    try:
        tree = ast.parse(text, mode="eval")
    except (SyntaxError, ValueError, RecursionError, MemoryError):
        raise InputError(f"{where}: cannot parse expression '= {shown}'") from None
    return ev(tree, 0)


# ------------------------------------------------------------------------------------------ SI values

def to_si(raw, kind: str, where: str, names: dict | None = None):
    """Convert a file value to SI for a quantity of `kind` (see KINDS). Plain numbers (a YAML number or a
    string holding only a number, e.g. a command-line value) are taken as SI. The result is finite, or a
    CasADi expression (an optimiser's symbolic parameter)."""
    unit, example = KINDS[kind]
    key, kind = kind, "plain number" if kind == "dimensionless" else kind
    a_kind = f"{'an' if kind[0] in 'aeiou' else 'a'} {kind}"
    if isinstance(raw, bool) or raw is None:
        raise InputError(f"{where}: expected {a_kind} like {example}, got {str(raw).lower() if isinstance(raw, bool) else 'nothing'}"
                         + (" (true/false are not numbers)" if isinstance(raw, bool) else ""))
    if isinstance(raw, (int, float)):
        try:
            value = float(raw)
        except OverflowError:       # a YAML integer of hundreds of digits
            value = math.inf
        if not math.isfinite(value):
            raise InputError(f"{where}: expected a finite {kind} like {example}, got {shorten(raw)}")
        return value
    if not isinstance(raw, str):
        return raw  # already a number-like (e.g. a CasADi symbol substituted by a study)
    text = raw.strip()
    if text.startswith("="):
        if text[1:].strip().isidentifier():
            _check_reference(text[1:].strip(), key, a_kind, example, names, where)
        return evaluate_expression(text[1:].strip(), names or {}, where)
    q = parse_quantity(text) if len(text) <= MAX_QUANTITY_TEXT else None
    if q is None:
        raise InputError(f"{where}: expected {a_kind} like {example}, got '{shorten(raw)}'")
    value, u = q
    if not math.isfinite(value):
        raise InputError(f"{where}: expected a finite {kind} like {example}, got '{shorten(raw)}'")
    if u is None:
        return value
    if dimension(u) not in dimensions(key):
        raise InputError(f"{where}: expected {a_kind} like {example}, got '{shorten(raw)}'"
                         f"{_kind_hint(key, a_kind, dimension(u))}")
    try:
        si = float(registry().Quantity(value, u).to(unit or "dimensionless").magnitude)
    except (pint.errors.DimensionalityError, pint.errors.UndefinedUnitError, ValueError, TypeError,
            AttributeError, AssertionError, OverflowError):
        raise InputError(f"{where}: expected {a_kind} like {example}, got '{shorten(raw)}'") from None
    if not math.isfinite(si):
        raise InputError(f"{where}: expected a finite {kind} like {example}, got '{shorten(raw)}' (beyond ±1.8e308 in SI)")
    return si


# the unit every printed quantity of a kind (units.KINDS, and power) is shown in, and its factor from SI
ENGINEERING = {
    "length": ("mm", 1e3), "force": ("N", 1.0), "torque": ("N·m", 1.0), "angle": ("°", 180 / math.pi),
    "pressure": ("MPa", 1e-6), "power": ("W", 1.0), "compliance": ("1/N", 1.0), "stiffness": ("N/mm", 1e-3),
    "speed": ("rad/s", 1.0), "dimensionless": ("", 1.0), "time": ("h", 1 / 3600), "frequency": ("Hz", 1.0),
    "inertia": ("kg·m²", 1.0),
}


def number(value, digits: int = 4) -> str:
    """`value` to `digits` significant digits, positional between 1e-4 and 1e7 (31.94, 0.0992, 143.5,
    12350), else with an exponent (1.2e-07); '—' for None or NaN."""
    if value is None or (isinstance(value, (float, np.floating)) and math.isnan(value)):
        return "—"
    value = float(value)
    if value == 0 or not math.isfinite(value):
        return "0" if value == 0 else f"{value}"
    if 1e-4 <= abs(value) < 1e7:
        return np.format_float_positional(value, precision=digits, unique=False, fractional=False, trim="-")
    return f"{value:.{digits}g}".replace("e-0", "e-").replace("e+0", "e+")


def engineering(value_si, kind: str, digits: int = 4) -> str:
    """An SI value of a kind (KINDS or 'power') in its engineering unit, with the unit (ENGINEERING):
    engineering(0.0319401, 'length') = '31.94 mm', engineering(0.0541, 'angle') = '3.1°' (angles in rad),
    engineering(6e6, 'pressure') = '6 MPa'; '—' for None or NaN. What tables, reports and notes show; a
    value as a file would write it (a bound in a message) is `typed`."""
    unit, factor = ENGINEERING[kind]
    text = number(None if value_si is None else float(value_si) * factor, digits)
    if text == "—" or not unit:
        return text
    return f"{text}°" if unit == "°" else f"{text} {unit}"


def degrees(value_deg, digits: int = 4) -> str:
    """An angle already in degrees (worst_alpha_deg, an objective in degrees): '3.1°'."""
    return engineering(None if value_deg is None else math.radians(value_deg), "angle", digits)


def si_text(value, kind, units=None) -> str:
    """A value as a plain number in a file means it: in its kind's SI unit (KINDS; N·m written with '·'), to 6
    significant digits; `units` (name, factor from SI) shows it in another."""
    name, k = units or (KINDS[kind][0].replace("*", "·"), 1.0)
    return f"{value * k:.6g}" + (f" {name}" if name else "")


def typed(value, kind) -> str:
    """A value as a file would write it, in the unit a designer types (mm below 1 m, kPa/MPa/GPa, deg): the
    bounds in messages and in the reference pages. Tables and reports show quantities with `engineering`."""
    if kind == "length" and abs(value) < 1:
        return si_text(value, kind, ("mm", 1e3))
    if kind == "pressure" and abs(value) >= 1e3:
        unit = next((u for u in (("GPa", 1e-9), ("MPa", 1e-6), ("kPa", 1e-3)) if abs(value) * u[1] >= 1))
        return si_text(value, kind, unit)
    if kind == "angle":
        return si_text(value, kind, ("deg", 180 / math.pi))
    return si_text(value, kind)


def check_range(value, raw, where: str, what: str, kind: str, lo=None, hi=None, lo_open=False, hi_open=False,
                guess: str | None = None):
    """`value` (SI, from the file's `raw`) within the plausible range of `what` (lo/hi in SI, None: unbounded),
    else one InputError line: "rollers.D1.radius: 45 m is not a plausible roller radius (expected at most
    1000 mm); did you mean '45 mm'?". `guess`: the unit a plain number probably meant (suggested when the
    number in that unit is in range). Symbolic values (an optimiser's parameters) pass unchecked."""
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        return value
    below = lo is not None and (value <= lo if lo_open else value < lo)
    above = hi is not None and (value >= hi if hi_open else value > hi)
    if not (below or above):
        return value
    if below:
        need = f"more than {typed(lo, kind)}" if lo_open else f"at least {typed(lo, kind)}"
    else:
        need = f"less than {typed(hi, kind)}" if hi_open else f"at most {typed(hi, kind)}"
    hint = ""
    if guess and is_plain_number(raw):
        alt = to_si(f"{float(raw) if not isinstance(raw, str) else raw.strip()} {guess}", kind, where)
        if not ((lo is not None and (alt <= lo if lo_open else alt < lo)) or
                (hi is not None and (alt >= hi if hi_open else alt > hi))):
            number = raw.strip() if isinstance(raw, str) else f"{raw:g}"
            hint = f"; did you mean '{number} {guess}'? (plain numbers are SI)"
    elif isinstance(raw, str) and raw.strip().startswith("="):
        hint = "; expressions are evaluated in SI (m, N, Pa, rad)"
    written = isinstance(raw, str) and not is_plain_number(raw) and not raw.strip().startswith("=")
    shown = f"'{shorten(raw.strip())}'" if written else si_text(value, kind)     # as written, if it has a unit
    raise InputError(f"{where}: {shown} is not a plausible {what} (expected {need}){hint}")
