"""A command line's options checked as a whole, before any work (cli.parser runs `check_options` with its
check of the output paths): no option given an empty value, no two outputs on one path, no file given as
inputs of two kinds, no two options that contradict each other. Each is one InputError line, so nothing is computed or written."""
from __future__ import annotations

import os

from cvtdesign.errors import InputError

OUTPUTS = ("--json", "--report", "--points", "--save-calibration", "--table", "--out", "--plots", "--store")
# options that contradict each other: (option, other, why neither can take effect with the other)
CONFLICTS = (
    ("--envelope", "--as-written", "evaluates every column on that file's envelope, and --as-written each on its "
                                   "own"),
    ("--workers", "--scheduler", "sizes a local cluster, and --scheduler runs on a cluster that has workers of its "
                                 "own"),
)


def check_options(args, actions) -> None:
    """Refuse (one InputError line) an option or argument given an empty value ('' from an unset shell variable
    used to become the default: `--table-ratios ''` wrote the default table, `--json ''` wrote nothing), two
    options that contradict each other (CONFLICTS), and two outputs on one path (the later replaced the
    earlier, and both were reported written). `actions`: the command's argparse actions."""
    names = {a.dest: (a.option_strings[-1] if a.option_strings else a.dest) for a in actions}
    for dest, value in vars(args).items():
        values = value if isinstance(value, list) else [value]
        if dest in names and any(isinstance(v, str) and not v.strip() for v in values):
            raise InputError(f"{names[dest]}: empty (an unset shell variable?); expected a value, or the option "
                             "left out for its default")
    for option, other, why in CONFLICTS:
        if _given(args, option) and _given(args, other):
            raise InputError(f"{option}: {why}; expected one of {option} and {other}")
    _one_path_each(args)
    _one_role_each(args, names)


INPUT_ROLES = ("variant", "variants", "study", "protocol", "calibration", "tolerances")   # input files of one kind each


def _one_role_each(args, names: dict) -> None:
    """A file given as inputs of two kinds (`tolerance v.yaml --tolerances v.yaml`) is refused in words, not
    read as the other kind ('parameters: unknown field'). (resteer's measured data and its variant are told
    apart by resteer itself.)"""
    seen: dict = {}
    for dest in INPUT_ROLES:
        given = getattr(args, dest, None)
        for path in [given] if isinstance(given, str) else given or []:
            if not os.path.isfile(path):
                continue
            key = os.path.realpath(path)
            if key in seen and seen[key] != dest:
                raise InputError(f"{names.get(dest, dest)}: {path} is also this command's {seen[key]}; expected a "
                                 f"{dest.rstrip('s') if dest == 'variants' else dest} file of its own")
            seen.setdefault(key, dest)


def _given(args, option: str) -> bool:
    value = getattr(args, option[2:].replace("-", "_"), None)
    return value is not None and value is not False


def _one_path_each(args) -> None:
    """Each output option names a path of its own (`--json o.csv --points o.csv` wrote the points over the JSON)."""
    seen: dict = {}
    for option in OUTPUTS:
        path = getattr(args, option[2:].replace("-", "_"), None)
        if not isinstance(path, str):
            continue
        key = os.path.realpath(path)
        if key in seen:
            raise InputError(f"{option}: {path} is also {seen[key]}'s path; expected a path of its own for each "
                             "output, so that neither replaces the other")
        seen[key] = option
