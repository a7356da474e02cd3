"""One table of bad inputs for every command and every file the tool reads, run through the CLI in-process.

The promise (README, "Errors come as one line"): a bad input gives exit status 2, exactly one non-empty line
on stderr (`cvtdesign: error: ...`, or argparse's `cvtdesign <command>: error: ...`) naming the file, field,
row or argument and what was expected, no traceback anywhere on stdout or stderr, and no new or changed file
in any output location.

Each case runs `cvtdesign.cli.main(argv)` in a fresh tmp_path laid out as
    work/   the working directory (monkeypatch.chdir), with copies of variants/ and studies/, so that a
            relative default (out/compare, results/<study>, cad_out) lands here and is seen;
    in/     the bad input files of the case, a regular file `plain.txt` (a folder that is a file) and a
            folder `adir` (a file that is a folder);
    out/    the output folder the case names, holding `old.json` and `old.csv` (a refused case must not
            replace them).
The whole tree is hashed before and after. Most cases fail before any model is compiled; none needs a solve.
A few cases at the end run the console script as a real subprocess, to prove the entry point itself.

Cases are `case(id, expect, build, command, file type)`: `build(env)` writes the case's files and returns
argv; `expect` is a substring (or a tuple of substrings) the one line must contain: the field, argument or
file named. A case the tool does not yet meet is kept, marked xfail(strict=True) with the reason.
"""
from __future__ import annotations

import contextlib
import copy
import hashlib
import math
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pytest
import yaml

from conftest import ROOT

from cvtdesign.cli import main

EXISTING = ROOT / "variants" / "existing_kim.yaml"
PLACEMENT = ROOT / "studies" / "box_placement_kim.yaml"
NAN, INF = float("nan"), float("inf")
DEL = object()                      # a mutation that deletes the key


class Whole(dict):
    """A study section given whole (not merged into the shipped one)."""


@dataclass
class Env:
    tmp: Path
    work: Path       # the working directory
    inp: Path        # the case's input files
    out: Path        # the output folder

    @property
    def plain(self) -> Path:          # a regular file
        return self.inp / "plain.txt"

    @property
    def adir(self) -> Path:           # a folder
        return self.inp / "adir"


def make_env(tmp: Path) -> Env:
    env = Env(tmp, tmp / "work", tmp / "in", tmp / "out")
    for sub in ("variants", "studies"):
        shutil.copytree(ROOT / sub, env.work / sub)
    env.adir.mkdir(parents=True)
    (env.adir / "inside.txt").write_text("kept\n")
    env.plain.write_text("a file, not a folder\n")
    env.out.mkdir()
    (env.out / "old.json").write_text('{"old": true}\n')
    (env.out / "old.csv").write_text("old\n")
    good_csv(env)
    return env


# ---------------------------------------------------------------------------------------------- builders

HEADER = "gamma_cmd_deg,omega_1,omega_2,tau_1,tau_2\n"
ROWS = "".join(f"{g},10,{10 * math.tan(math.radians(g)):.5f},{t},{t}\n"
               for g in range(-60, 61, 20) for t in (-0.5, 0.0, 0.5))      # 21 operating points


def good_csv(env: Env) -> Path:
    f = env.inp / "good.csv"
    if not f.exists():
        f.write_text(HEADER + ROWS)
    return f


def _set(data, path, value):
    node = data
    for k in path[:-1]:
        node = node[k] if isinstance(node, list) else node.setdefault(k, {})
    if value is DEL:
        del node[path[-1]]
    else:
        node[path[-1]] = value


def _write(path: Path, content) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    (path.write_bytes if isinstance(content, bytes) else path.write_text)(content)
    return path


def bad_variant(env: Env, edits=(), raw=None, name="bad.yaml") -> Path:
    """existing_kim.yaml with `edits` ((path, value) pairs, value DEL to delete; or a callable on the data), or
    `raw` text/bytes (a function of the shipped text, or the content itself), written to in/<name>."""
    if raw is not None:
        content = raw(EXISTING.read_text()) if callable(raw) else raw
        return _write(env.inp / name, content)
    data = copy.deepcopy(yaml.safe_load(EXISTING.read_text()))
    for e in edits:
        if callable(e):
            e(data)
        else:
            _set(data, *e)
    return _write(env.inp / name, yaml.safe_dump(data, sort_keys=False, allow_unicode=True))


def compare(*edits, raw=None):
    def build(env):
        f = bad_variant(env, edits, raw)
        return ["compare", str(f), "--out", str(env.out / "plots"), "--json", str(env.out / "c.json")]
    return build


def with_variant(command, *edits, raw=None, missing=False):
    """Another command given the bad variant (or a variant file that does not exist)."""
    def build(env):
        f = env.inp / "nope.yaml" if missing else bad_variant(env, edits, raw)
        o = env.out
        return {"export": ["export", str(f), "--out", str(o / "cad")],
                "rig": ["rig", str(f), "--out", str(o / "d.csv")],
                "diagnose": ["diagnose", str(good_csv(env)), "--variant", str(f), "--json", str(o / "r.json")],
                "resteer": ["resteer", "--variant", str(f), "--load", "1 N*m", "--json", str(o / "r.json")],
                "selfcheck": ["selfcheck", "--variant", str(f), "--quick", "--json", str(o / "s.json")],
                "optimise": ["optimise", str(_study_file(env, {"base": str(f)})), "--out", str(o / "res")],
                }[command]
    return build


def _study_file(env, fields, raw=None, name="bad_study.yaml") -> Path:
    """studies/box_placement_kim.yaml (in the working directory's copy, so its base ../variants/box_kim.yaml resolves
    there) with `fields` merged into its sections (a dict merges, DEL deletes, else replaces)."""
    if raw is not None:
        return _write(env.work / "studies" / name, raw)
    data = yaml.safe_load(PLACEMENT.read_text())
    for k, v in fields.items():
        if v is DEL:
            data.pop(k, None)
        elif isinstance(v, Whole):
            data[k] = dict(v)
        elif isinstance(v, dict) and isinstance(data.get(k), dict):
            for kk, vv in v.items():
                if vv is DEL:
                    data[k].pop(kk, None)
                else:
                    data[k][kk] = vv
        else:
            data[k] = v
    return _write(env.work / "studies" / name, yaml.safe_dump(data, sort_keys=False, allow_unicode=True))


def optimise(raw=None, extra=(), **fields):
    def build(env):
        f = _study_file(env, fields, raw)
        return ["optimise", str(f), "--out", str(env.out / "res"), "--json", str(env.out / "o.json"), *extra]
    return build


def study(raw=None, extra=(), **fields):
    def build(env):
        f = _study_file(env, fields, raw)
        return ["study", str(f), "--out", str(env.out / "store"), "--workers", "1", *extra]
    return build


def protocol(content):
    """rig with --protocol: a dict is dumped as YAML, text or bytes written as they are."""
    def build(env):
        text = yaml.safe_dump(content, sort_keys=False) if isinstance(content, (dict, list)) else content
        f = _write(env.inp / "protocol.yaml", text)
        return ["rig", str(env.work / "variants" / "existing_kim.yaml"), "--protocol", str(f),
                "--out", str(env.out / "d.csv")]
    return build


def diagnose(content, *extra):
    def build(env):
        f = _write(env.inp / "data.csv", content)
        return ["diagnose", str(f), "--variant", str(env.work / "variants" / "existing_kim.yaml"),
                "--json", str(env.out / "r.json"), "--plots", str(env.out / "plots"), *extra]
    return build


def cli(*args):
    """A command line: {v} the working copy of existing_kim.yaml, {csv} a good measured-data file, {out} the output
    folder, {in} the input folder, {plain} a regular file, {adir} a folder, {tmp} the case's tmp_path."""
    def build(env):
        keys = {"v": env.work / "variants" / "existing_kim.yaml", "csv": good_csv(env), "out": env.out, "in": env.inp,
                "plain": env.plain, "adir": env.adir, "tmp": env.tmp}
        return [a.format(**keys) for a in args]
    return build


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def scheduler_nobody(command):
    def build(env):
        addr = f"tcp://127.0.0.1:{free_port()}"
        if command == "study":
            return ["study", str(env.work / "studies" / "box_placement_kim.yaml"), "--scheduler", addr,
                    "--out", str(env.out / "store")]
        return ["selfcheck", "--matrices", "independent", "--quick", "--scheduler", addr,
                "--json", str(env.out / "s.json")]
    return build


CASES: list = []
COMMAND_OF: dict = {}      # case id -> (command, file type read), for the coverage test


def case(id, expect, build, command, kind, xfail=None, slow=False):
    assert id not in COMMAND_OF, id
    COMMAND_OF[id] = (command, kind)
    marks = ([pytest.mark.xfail(strict=True, reason=xfail)] if xfail else []) + ([pytest.mark.slow] if slow else [])
    CASES.append(pytest.param(build, expect, id=id, marks=marks))


# ------------------------------------------------------------------------------------- variant YAML: compare

D1, S1 = ("rollers", "D1"), ("rollers", "S1")
M82, M84 = ("materials", "urethane_82A"), ("materials", "urethane_84A")
ENV_G, ENV_L = ("envelope", "gamma"), ("envelope", "load")
EP = ("effect_parameters",)
FORK0 = ("steering", "forks", 0)


def vcase(id, expect, *edits, raw=None, xfail=None):
    """A bad variant file run through `compare`; the line must also name the file."""
    exp = (expect,) if isinstance(expect, str) else tuple(expect)
    case(f"compare: {id}", ("bad.yaml",) + exp, compare(*edits, raw=raw), "compare", "variant YAML", xfail)


# the file itself
case("compare: missing file", ("nope.yaml", "cannot read file"), cli("compare", "{in}/nope.yaml", "--out", "{out}/p"),
     "compare", "variant YAML")
case("compare: a directory instead of a file", ("adir", "cannot read file"),
     cli("compare", "{adir}", "--out", "{out}/p"), "compare", "variant YAML")
case("compare: second of two files missing", "nope.yaml", cli("compare", "{v}", "{in}/nope.yaml", "--out", "{out}/p"),
     "compare", "variant YAML")
vcase("empty file", "expected a YAML mapping", raw="")
vcase("only a comment", "expected a YAML mapping", raw="# nothing here\n")
vcase("not YAML", "not valid YAML (line 2)", raw="name: [unclosed\n  rollers: x\n")
vcase("tab indentation", "not valid YAML", raw="name: x\n\trollers: 1\n")
vcase("a YAML list", "expected a YAML mapping", raw="- name: existing\n- 2\n")
vcase("a YAML scalar", "expected a YAML mapping", raw="just some text\n")
vcase("Latin-1 bytes", "not UTF-8", raw=lambda t: t.replace("Kim's", "Kim’s").encode("utf-8").replace(
    "’".encode(), b"\xe9"))
vcase("a PNG file", "not UTF-8 text (byte 0x89)", raw=b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256)))
vcase("NUL byte in the text", "not valid YAML", raw=lambda t: t.replace("description:", "descr\x00iption:"))
vcase("escape character in the text", "not valid YAML", raw=lambda t: t.replace("description:", "# \x1b[2J\ndescription:"))
vcase("duplicate top-level key", "duplicate key 'name'", raw=lambda t: t + "name: again\n")
vcase("duplicate material", "duplicate key 'urethane_84A'", raw=lambda t: t.replace(
    "  bowling_ball:", "  urethane_84A: {youngs_modulus: 12 MPa, poisson_ratio: 0.48}\n  bowling_ball:"))
vcase("recursive alias", "YAML", raw="a: &a [*a]\n")
# schema: unknown and missing fields
vcase("unknown top-level key", "colour: unknown field", (("colour",), "red"))
vcase("top-level typo", "did you mean 'envelope'", (("envelope",), DEL), (("envelop",), {"motor_speed": "10 rad/s"}))
vcase("roller field typo", ("rollers.D1.crown_radis", "did you mean 'crown_radius'"),
      (D1 + ("crown_radius",), DEL), (D1 + ("crown_radis",), "15 mm"))
vcase("material field typo", ("youngs_modulas", "did you mean 'youngs_modulus'"),
      (M82 + ("youngs_modulus",), DEL), (M82 + ("youngs_modulas",), "10.7 MPa"))
vcase("envelope field typo", ("envelope.gama", "did you mean 'gamma'"), (ENV_G, DEL),
      (("envelope", "gama"), {"start": "-80 deg", "stop": "80 deg", "step": "10 deg"}))
vcase("fork field typo", ("steering.forks.0.axes", "did you mean 'axis'"), (FORK0 + ("axis",), DEL),
      (FORK0 + ("axes",), "c1"))
for field in ("name", "sphere", "rollers", "steering"):
    vcase(f"missing {field}", f"{field}: missing required field", ((field,), DEL))
vcase("material in neither the variant nor the library", ("unknown material 'urethane_99A'", "did you mean"),
      (D1 + ("material",), "urethane_99A"))
vcase("material library that is not there", "material_library[0]: no such file", (("material_library",), ["no.yaml"]))
for field in ("role", "contact", "axle"):
    vcase(f"roller without {field}", f"rollers.D1.{field}: missing required field", (D1 + (field,), DEL))
for field in ("radius", "material"):     # these may come from roller_defaults instead
    vcase(f"roller without {field}", f"rollers.D1.{field}: missing (give it on the roller or in roller_defaults)",
          (D1 + (field,), DEL))
vcase("sphere without radius", "sphere.radius: missing required field", (("sphere", "radius"), DEL))
vcase("material without poisson_ratio", "urethane_82A.poisson_ratio: missing", (M82 + ("poisson_ratio",), DEL))
vcase("fork without rollers", "steering.forks.0.rollers: missing", (FORK0 + ("rollers",), DEL))
vcase("envelope range without step", "envelope.gamma.step: missing", (ENV_G + ("step",), DEL))
vcase("unknown role", "rollers.D1.role", (D1 + ("role",), "driver"))
vcase("shaft 3", "rollers.D1.shaft", (D1 + ("shaft",), 3))
vcase("rollers as a list", "rollers", (("rollers",), ["D1", "D2"]))
vcase("fork sign 2", "steering.forks.0.sign", (FORK0 + ("sign",), 2))
vcase("name with a space", "name: expected a name of letters", (("name",), "my variant"))
# wrong units, one per quantity field
WRONG_UNITS = [
    ("sphere.radius", ("sphere", "radius"), "63.5 N"),
    ("rollers.D1.radius", D1 + ("radius",), "40 kg"),
    ("rollers.D1.crown_radius", D1 + ("crown_radius",), "15 s"),
    ("rollers.D1.width", D1 + ("width",), "24 N"),
    ("rollers.D1.preload", D1 + ("preload",), "100 mm"),
    ("rollers.D1.mount_stiffness", D1 + ("mount_stiffness",), "1e5 N"),
    ("rollers.D1.ratio", D1 + ("ratio",), "1 mm"),
    ("roller_defaults.preload", ("roller_defaults", "preload"), "100 m"),
    ("urethane_82A.youngs_modulus", M82 + ("youngs_modulus",), "10.7 mm"),
    ("urethane_82A.poisson_ratio", M82 + ("poisson_ratio",), "0.48 mm"),
    ("pairs.0.friction", ("pairs", 0, "friction"), "0.8 N"),
    ("urethane_82A.allowable_pressure", M82 + ("allowable_pressure",), "6 N"),
    ("contact.creep_drive", ("contact", "creep_drive"), "0.0038 N"),
    ("contact.creep_steering", ("contact", "creep_steering"), "0.0049 m"),
    ("contact.creep_reference_force", ("contact", "creep_reference_force"), "100 mm"),
    ("envelope.gamma.start", ENV_G + ("start",), "-80 mm"),
    ("envelope.gamma.step", ENV_G + ("step",), "10 N"),
    ("envelope.load.stop", ENV_L + ("stop",), "1 N"),
    ("envelope.load.step", ENV_L + ("step",), "0.1 m"),
    ("envelope.motor_speed", ("envelope", "motor_speed"), "10 N"),
    ("rollers.D1.contact.polar", D1 + ("contact",), {"polar": "30 mm", "azimuth": "0 deg"}),
    ("rolling_resistance.offset", EP, {"rolling_resistance": {"offset": "0.1 N"}}),
    ("rollers.D1.radius", D1 + ("radius",), "40 furlongz"),
]
for name, path, value in WRONG_UNITS:
    vcase(f"wrong unit {name} = {value!r}"[:90], name, (path, value))
# non-positive values
NON_POSITIVE = [
    ("sphere.radius", ("sphere", "radius"), "0 mm"),
    ("sphere.radius", ("sphere", "radius"), "-63.5 mm"),
    ("rollers.S1.radius", S1 + ("radius",), "-38 mm"),
    ("rollers.D1.crown_radius", D1 + ("crown_radius",), "0 mm"),
    ("rollers.D1.width", D1 + ("width",), "-24 mm"),
    ("rollers.D1.preload", D1 + ("preload",), "0 N"),
    ("roller_defaults.preload", ("parameters", "preload"), "-100 N"),
    ("roller_defaults.mount_stiffness", ("roller_defaults", "mount_stiffness"), "0 N/m"),
    ("urethane_82A.youngs_modulus", M82 + ("youngs_modulus",), "0 MPa"),
    ("pairs.0.friction", ("pairs", 0, "friction"), 0),
    ("pairs.0.friction", ("pairs", 0, "friction"), -0.8),
    ("contact.creep_drive", ("contact", "creep_drive"), "0 1/N"),
    ("contact.creep_steering", ("contact", "creep_steering"), "-0.0049 1/N"),
    ("contact.creep_reference_force", ("contact", "creep_reference_force"), "0 N"),
    ("envelope.motor_speed", ("envelope", "motor_speed"), "0 rad/s"),
    ("envelope.motor_speed", ("envelope", "motor_speed"), "-10 rad/s"),
    ("rollers.D1.ratio", D1 + ("ratio",), 0),
]
for name, path, value in NON_POSITIVE:
    vcase(f"non-positive {name} = {value!r}", name, (path, value))
# non-finite values (YAML's .nan/.inf and quantities like 'inf mm')
NON_FINITE = [
    ("sphere.radius", ("sphere", "radius"), NAN),
    ("rollers.D1.radius", D1 + ("radius",), "-inf mm"),
    ("rollers.D1.crown_radius", D1 + ("crown_radius",), NAN),
    ("rollers.D1.width", D1 + ("width",), "inf mm"),
    ("rollers.D1.preload", D1 + ("preload",), NAN),
    ("roller_defaults.mount_stiffness", ("roller_defaults", "mount_stiffness"), "nan N/m"),
    ("urethane_82A.youngs_modulus", M82 + ("youngs_modulus",), "inf MPa"),
    ("urethane_82A.poisson_ratio", M82 + ("poisson_ratio",), NAN),
    ("pairs.0.friction", ("pairs", 0, "friction"), INF),
    ("urethane_82A.allowable_pressure", M82 + ("allowable_pressure",), NAN),
    ("contact.creep_drive", ("contact", "creep_drive"), "inf 1/N"),
    ("envelope.motor_speed", ("envelope", "motor_speed"), INF),
    ("envelope.load.start", ENV_L + ("start",), NAN),
    ("envelope.gamma.step", ENV_G + ("step",), NAN),
    ("parameters.preload", ("parameters", "preload"), "nan N"),
    ("parameters.r_steer", ("parameters", "r_steer"), INF),
    ("rollers.D1.contact.polar", D1 + ("contact",), {"polar": NAN, "azimuth": "0 deg"}),
    ("rolling_resistance.offset", EP, {"rolling_resistance": {"offset": NAN}}),
]
for name, path, value in NON_FINITE:
    vcase(f"non-finite {name} = {value!r}", name, (path, value))
# booleans are not numbers
BOOLEANS = [
    ("sphere.radius", ("sphere", "radius")), ("rollers.D1.radius", D1 + ("radius",)),
    ("rollers.D1.preload", D1 + ("preload",)), ("roller_defaults.mount_stiffness", ("roller_defaults", "mount_stiffness")),
    ("pairs.0.friction", ("pairs", 0, "friction")), ("urethane_82A.poisson_ratio", M82 + ("poisson_ratio",)),
    ("urethane_82A.youngs_modulus", M82 + ("youngs_modulus",)), ("envelope.motor_speed", ("envelope", "motor_speed")),
    ("envelope.gamma.step", ENV_G + ("step",)), ("parameters.preload", ("parameters", "preload")),
    ("steering.forks.0.sign", FORK0 + ("sign",)), ("rollers.D1.shaft", D1 + ("shaft",)),
    ("rollers.D1.ratio", D1 + ("ratio",)), ("contact.creep_drive", ("contact", "creep_drive")),
]
for k, (name, path) in enumerate(BOOLEANS):
    vcase(f"boolean {name}", name, (path, k % 2 == 0))
vcase("boolean in a contact vector", "rollers.D1.contact", (D1 + ("contact",), [1, False, 0]))
vcase("boolean effect parameter", "drive_longitudinal_creep.scale", (EP, {"drive_longitudinal_creep": {"scale": True}}))
# bad vectors
VECTORS = [
    ("contact of 2 numbers", "rollers.D1.contact", D1 + ("contact",), [1, 0]),
    ("contact of 4 numbers", "rollers.D1.contact", D1 + ("contact",), [1, 0, 0, 0]),
    ("zero contact", "rollers.D1.contact", D1 + ("contact",), [0, 0, 0]),
    ("infinite contact", "rollers.D1.contact", D1 + ("contact",), [0, INF, 0]),
    ("unknown frame name", "rollers.D1.contact", D1 + ("contact",), "d4"),
    ("empty frame name", "rollers.D1.contact", D1 + ("contact",), ""),
    ("a lone minus sign", "rollers.D1.contact", D1 + ("contact",), "-"),
    ("a number as contact", "rollers.D1.contact", D1 + ("contact",), 5),
    ("axle unknown name", "rollers.D1.axle", D1 + ("axle",), "q"),
    ("zero axle", "rollers.D1.axle", D1 + ("axle",), [0, 0, 0]),
    ("axle of 2 numbers", "rollers.D1.axle", D1 + ("axle",), [1, 2]),
    ("fork axis unknown name", "steering.forks[0].axis", FORK0 + ("axis",), "w"),
    ("zero fork axis", "steering.forks[0].axis", FORK0 + ("axis",), [0, 0, 0]),
    ("polar without azimuth", "rollers.D1.contact", D1 + ("contact",), {"polar": "30 deg"}),
    ("polar, azimuth and more", "rollers.D1.contact", D1 + ("contact",), {"polar": "30 deg", "azimuth": 0, "r": 1}),
    ("a point of 2 lengths", "rollers.D1.contact", D1 + ("contact",), ["1 mm", "0 mm"]),
    ("numbers and lengths mixed", "rollers.D1.contact", D1 + ("contact",), [1, "0 mm", 0]),
]
for id, expect, path, value in VECTORS:
    vcase(id, expect, (path, value))
# geometry
vcase("axle along the contact", "rollers.D1.axle: not perpendicular", (D1 + ("axle",), "d2"))
vcase("steering axle along its contact", "rollers.S1.axle: not perpendicular", (S1 + ("axle",), "c1"))
vcase("axle [0, 1, 1]", "rollers.D1.axle: not perpendicular", (D1 + ("axle",), [0, 1, 1]))
vcase("contact point inside the sphere", ("rollers.D1.contact", "must lie on the sphere"),
      (D1 + ("contact",), ["0 mm", "0 mm", "60 mm"]), (D1 + ("axle",), "x"))
vcase("contact point at the centre", ("rollers.D1.contact", "must lie on the sphere"),
      (D1 + ("contact",), ["0 mm", "0 mm", "0 mm"]))
vcase("preloads that do not balance (D1)", "preload", (D1 + ("preload",), "200 N"))
vcase("preloads that do not balance (S1)", "preload", (S1 + ("preload",), "50 N"))
vcase("forks: []", "steering", (("steering", "forks"), []))
vcase("fork with rollers: []", "steering.forks[0].rollers: empty", (FORK0 + ("rollers",), []))
vcase("fork with an unknown roller", ("steering.forks[0].rollers", "did you mean 'S1'"), (FORK0 + ("rollers",), ["S11"]))
vcase("fork holding a drive roller", "steering.forks[0].rollers: 'D1' is a drive roller", (FORK0 + ("rollers",), ["D1"]))
vcase("a roller on two forks", "steering.forks[1].rollers: 'S1' is already on another fork",
      (("steering", "forks", 1, "rollers"), ["S1"]))
vcase("a steering roller on no fork", "rollers.S2: steering roller is on no fork",
      (("steering", "forks"), [{"rollers": ["S1"], "axis": "c1", "sign": 1}]))
vcase("fork with ratio and sign", "steering.forks[0]: gives both ratio and sign", (FORK0 + ("ratio",), 1))
vcase("fork ratio 0", "steering.forks[0].ratio: 0 is not a plausible fork gear ratio", (FORK0 + ("sign",), DEL),
      (FORK0 + ("ratio",), 0))
vcase("fork ratio 1000", "steering.forks[0].ratio: 1000 is not a plausible", (FORK0 + ("sign",), DEL),
      (FORK0 + ("ratio",), 1000))
vcase("fork ratio with a unit", "steering.forks[0].ratio", (FORK0 + ("sign",), DEL), (FORK0 + ("ratio",), "2 mm"))
vcase("fork ratio that does not fit the other fork", ("steering.forks: S2's axle does not pass through the "
      "commanded axis that S1 steers", "fix S2 with steering.forks[1].ratio: -2"), (FORK0 + ("sign",), DEL),
      (FORK0 + ("ratio",), 2))
vcase("a steering roller with a shaft", "rollers.S1.shaft", (S1 + ("shaft",), 1))
vcase("a drive roller without a shaft", "rollers.D1.shaft", (D1 + ("shaft",), DEL))
vcase("no drive roller on shaft 2", "shaft 2", (("rollers", "D2", "shaft"), 1))
vcase("rollers: {}", "rollers", (("rollers",), {}))
vcase("unknown roller material", ("rollers.D1.material", "unknown material 'stel'", "did you mean 'steel'"),
      (D1 + ("material",), "stel"))
vcase("unknown sphere material", ("sphere.material", "did you mean 'bowling_ball'"), (("sphere", "material"), "bowlingball"))
vcase("Poisson ratio 0.7", "urethane_82A.poisson_ratio", (M82 + ("poisson_ratio",), 0.7))
# a parameter written with a unit of another kind than the field that takes it (it used to become SI silently:
# 'preload: 100 mm' gave every roller 0.1 N, and compare printed max |α| 0.000)
vcase("parameter of the wrong kind: preload in mm",
      ("roller_defaults.preload", "'= preload' is parameter preload = '100 mm', not a force"),
      (("parameters", "preload"), "100 mm"))
vcase("parameter of the wrong kind: radius in deg",
      ("rollers.S1.radius", "'= r_steer' is parameter r_steer = '2.18 deg', not a length"),
      (("parameters", "r_steer"), "2.18 deg"))
# effects
vcase("unknown effect", "effects: unknown effect 'spin_creep'", (("effects",), ["spin_creep"]))
vcase("misspelt effect", "did you mean 'rolling_resistance'", (("effects",), ["drive_longitudinal_creep", "rolling_resistence"]))
vcase("effects as a string", "effects", (("effects",), "drive_longitudinal_creep"))
vcase("unknown effect in effect_parameters", "effect_parameters.rolling_resistence: unknown effect",
      (EP, {"rolling_resistence": {"offset": "0.1 mm"}}))
vcase("unknown effect parameter", ("effect_parameters.rolling_resistance.ofset", "did you mean 'offset'"),
      (EP, {"rolling_resistance": {"ofset": "0.1 mm"}}))
for eff, par, val in [("steering_offset", "offset", "30 deg"), ("drive_radius_mismatch", "delta", 0.5),
                      ("normal_force_variation", "exponent", 4), ("drive_spin_creep", "scale", 500),
                      ("traction_saturation", "mu_scale", 10), ("rolling_resistance", "offset", "6 mm")]:
    vcase(f"{eff}.{par} = {val} out of range", f"effect_parameters.{eff}.{par}", (EP, {eff: {par: val}}))
# envelope
vcase("gamma stop < start", "envelope.gamma: expected start <= stop", (ENV_G + ("stop",), "-60 deg"), (ENV_G + ("start",), "80 deg"))
vcase("gamma stop at 90 deg", ("envelope.gamma.stop: γ = 90 deg is where the sphere's axis is square to the "
                              "motor's shaft 1", "expected a γ clear of ±90 deg"), (ENV_G + ("stop",), "90 deg"))
vcase("gamma grid through 90 deg", ("envelope.gamma: point 17: γ = 90 deg", "clear of ±90 deg"),
      (ENV_G + ("stop",), "170 deg"))
vcase("motor speed expression over a parameter", ("envelope.motor_speed: unknown name 'R' in expression",
                                                  "the parameters this field can use: none"),
      (("envelope", "motor_speed"), "= 2*R"))
vcase("gamma step 0", "envelope.gamma: expected start <= stop and step > 0", (ENV_G + ("step",), "0 deg"))
vcase("load step < 0", "envelope.load: expected start <= stop and step > 0", (ENV_L + ("step",), "-0.1 N*m"))
vcase("a load grid of 2e7 points", "envelope.load.step", (ENV_L + ("step",), "1e-7 N*m"))
vcase("gamma beyond 180 deg", "envelope.gamma.start", (ENV_G + ("start",), "-200 deg"))
vcase("load of 2e4 N*m", "envelope.load.stop", (ENV_L + ("stop",), "2e4 N*m"))
vcase("motor speed 2e4 rad/s", "envelope.motor_speed", (("envelope", "motor_speed"), "2e4 rad/s"))
# expressions
EXPRESSIONS = [
    ("= 1/0", "sphere.radius", ("sphere", "radius"), "= 1/0"),
    ("= 10**400", "rollers.D1.radius", D1 + ("radius",), "= 10**400"),
    ("unknown name", "rollers.S1.radius", S1 + ("radius",), "= r_stear"),
    ("syntax error", "rollers.S1.radius", S1 + ("radius",), "= 2 *"),
    ("a function call that is not allowed", "rollers.S1.radius", S1 + ("radius",), "= __import__('os')"),
    ("an attribute", "rollers.S1.radius", S1 + ("radius",), "= r_steer.real"),
    ("a string literal", "rollers.S1.radius", S1 + ("radius",), "= 'a'"),
    ("a unit after an expression", "rollers.S1.radius", S1 + ("radius",), "= r_steer mm"),
]
for id, expect, path, value in EXPRESSIONS:
    vcase(f"expression {id}", expect, (path, value))
# plain numbers are SI: implausible ones
IMPLAUSIBLE = [
    ("rollers.S1.radius", S1 + ("radius",), 38, "did you mean '38 mm'"),
    ("rollers.D1.crown_radius", D1 + ("crown_radius",), 15, "did you mean '15 mm'"),
    ("rollers.D1.width", D1 + ("width",), 24, "did you mean '24 mm'"),
    ("urethane_84A.youngs_modulus", M84 + ("youngs_modulus",), 12.3, "did you mean '12.3 MPa'"),
    ("urethane_82A.allowable_pressure", M82 + ("allowable_pressure",), 6, "did you mean '6 MPa'"),
    ("rollers.S1.radius", ("parameters", "r_steer"), 38, "not a plausible roller radius"),
]
for name, path, value, hint in IMPLAUSIBLE:
    vcase(f"implausible plain number {path[-1]}: {value}", (name, hint), (path, value))
# the mounting plate (read by every command, drawn by export)
vcase("frame.distance < 0", "frame.distance", (("frame",), {"side": "-z", "distance": "-1 mm"}))
vcase("frame.thickness 0", "frame.thickness", (("frame",), {"side": "-z", "distance": "200 mm", "thickness": "0 mm"}))
vcase("frame.side unknown", "frame.side", (("frame",), {"side": "up", "distance": "200 mm"}))
vcase("frame.distance plain 200", ("frame.distance", "did you mean '200 mm'"), (("frame",), {"side": "-z", "distance": 200}))
# output locations
for id, expect, args in [
    ("--json to a directory", ("--json", "is a directory"), ("--json", "{adir}")),
    ("--json under a file", ("--json", "plain.txt is not a folder"), ("--json", "{plain}/x.json")),
    ("--json in a missing folder", ("--json", "no folder"), ("--json", "{tmp}/nowhere/deeper/x.json")),
    ("--json to /dev/null", ("--json", "character device"), ("--json", "/dev/null")),
    ("--out is a file", ("--out", "is not a folder"), ("--out", "{plain}")),
    ("--out under a file", ("--out", "lies under"), ("--out", "{plain}/plots")),
]:
    case(f"compare: {id}", expect, cli("compare", "{v}", *args), "compare", "command line")
case("compare: no variant file", ("compare", "variants"), cli("compare"), "compare", "command line")
case("compare: unknown option", "unrecognized arguments: --colour", cli("compare", "{v}", "--colour", "red"),
     "compare", "command line")
case("unknown command", "invalid choice: 'compar'", cli("compar", "{v}"), "-", "command line")

# ------------------------------------------------------------------------------- study YAML: optimise, study

case("optimise: missing study file", ("nope.yaml", "cannot read file"), cli("optimise", "{in}/nope.yaml"),
     "optimise", "study YAML")
case("optimise: a directory as study", ("adir", "cannot read file"), cli("optimise", "{adir}"), "optimise", "study YAML")


def scase(id, expect, command="optimise", xfail=None, **kw):
    exp = (expect,) if isinstance(expect, str) else tuple(expect)
    case(f"{command}: {id}", ("bad_study.yaml",) + exp, (optimise if command == "optimise" else study)(**kw),
         command, "study YAML", xfail)


scase("empty study", "expected a YAML mapping", raw="")
scase("study not YAML", "not valid YAML", raw="name: [x\n base: y\n")
scase("study is a list", "expected a YAML mapping", raw="- name: x\n")
scase("duplicate key in study", "duplicate key 'design'", raw=PLACEMENT.read_text() + "design: {}\n")
scase("NUL byte in the study", "not valid YAML", raw=PLACEMENT.read_text().replace("name:", "\x00name:"))
scase("non-UTF-8 study", "not UTF-8", raw=PLACEMENT.read_bytes().replace(b"Where", b"Wh\xe8re"))
scase("unknown top-level key", ("objectve", "did you mean 'objective'"), objectve={"kind": "worst_alpha"})
scase("missing name", "name: missing required field", name=DEL)
scase("missing base", "base: missing required field", base=DEL)
scase("missing design", "design: missing required field", design=DEL)
scase("base file that does not exist", "base: no variant file 'nope.yaml'", base="nope.yaml")
case("optimise: base is a folder", ("bad_study.yaml: base: '.' is a folder; expected a variant file",), optimise(base="."),
     "optimise", "study YAML")
case("optimise: base is the study itself", ("bad_study.yaml: base: 'bad_study.yaml' is the study itself",),
     optimise(base="bad_study.yaml"), "optimise", "study YAML")
case("optimise: calibration is a folder", ("bad_study.yaml: calibration: '.' is a folder; expected a diagnosis report",),
     optimise(calibration="."), "optimise", "study YAML")
case("optimise: base variant with an unknown field", ("bad.yaml", "rollers.D1.radus: unknown field"),
     with_variant("optimise", (D1 + ("radius",), DEL), (D1 + ("radus",), "40 mm")), "optimise", "study YAML")
scase("unknown design variable", ("design.dd", "did you mean 'd'"), design={"dd": {"lower": "30 mm", "upper": "90 mm"}})
scase("no design variables", "design: no design variables", design=Whole())
scase("design variable without upper", "design.d.upper: missing required field", design={"d": {"lower": "30 mm"}})
scase("design variable field typo", ("design.d.lowr", "did you mean 'lower'"),
      design={"d": {"lowr": "30 mm", "upper": "90 mm"}})
scase("inverted bounds", "design.r_drive: inverted bounds", design={"r_drive": {"lower": "60 mm", "upper": "20 mm"}})
scase("equal bounds", "design.d: equal bounds", design={"d": {"lower": "30 mm", "upper": "30 mm"}})
scase("negative radius bound", ("design.r_steer.lower: at '-20 mm' the variant is not valid:",
                                 "rollers.N1.radius: expected a positive radius"), design={"r_steer": {"lower": "-20 mm", "upper": "60 mm"}})
scase("force bounds on a length", "design.r_steer.lower", design={"r_steer": {"lower": "20 N", "upper": "60 N"}})
scase("length bounds on a force", "design.preload.lower", design={"preload": {"lower": "40 mm", "upper": "300 mm"}})
scase("bounds of two dimensions", "design.d", design={"d": {"lower": "30 mm", "upper": "110 N"}})
scase("bound nan", "design.d.lower", design={"d": {"lower": NAN, "upper": "110 mm"}})
scase("bound true", "design.d.upper", design={"d": {"lower": "30 mm", "upper": True}})
scase("design variable in a missing variant", "design.d.variants",
      design={"d": {"lower": "30 mm", "upper": "110 mm", "variants": ["../variants/nope.yaml"]}})
scase("unknown objective kind", "objective.kind", objective={"kind": "worst_slip"})
scase("objective field typo", ("objective.knd", "did you mean 'kind'"), objective={"knd": "worst_alpha"})
scase("duty-cycle weight < 0", "objective.duty_cycle[0].weight",
      objective={"kind": "power_loss", "duty_cycle": [{"gamma": "30 deg", "load": "1 N*m", "weight": -1}]})
scase("duty-cycle γ at -90 deg", "objective.duty_cycle[0].gamma: γ = -90 deg is where",
      objective={"kind": "power_loss", "duty_cycle": [{"gamma": "-90 deg", "load": "1 N*m", "weight": 1}]})
scase("duty-cycle weights all 0", "objective.duty_cycle: every weight is 0",
      objective={"kind": "power_loss", "duty_cycle": [{"gamma": "30 deg", "load": "1 N*m", "weight": 0}]})
scase("duty-cycle load in N", "objective.duty_cycle[0].load",
      objective={"kind": "power_loss", "duty_cycle": [{"gamma": "30 deg", "load": "1 N"}]})
scase("negative clearance", "constraints.clearance", constraints={"clearance": "-1 mm"})
scase("clearance in kg", "constraints.clearance", constraints={"clearance": "2 kg"})
scase("traction_margin 1", "constraints.traction_margin", constraints={"traction_margin": 1})
scase("traction_margin 1.5", "constraints.traction_margin", constraints={"traction_margin": 1.5})
scase("traction_margin true", "constraints.traction_margin", constraints={"traction_margin": True})
scase("envelope_radius 0", "constraints.envelope_radius", constraints={"envelope_radius": "0 mm"})
scase("hertz_pressure 'yes'", "constraints.hertz_pressure", constraints={"hertz_pressure": "yes"})
scase("reach_gamma 2", "constraints.reach_gamma", constraints={"reach_gamma": 2})
scase("min_normal_force in mm", "constraints.min_normal_force", constraints={"min_normal_force": "5 mm"})
scase("min_normal_force 0 N", "constraints.min_normal_force", constraints={"min_normal_force": "0 N"})
scase("min_normal_force < 0", "constraints.min_normal_force", constraints={"min_normal_force": "-5 N"})
scase("min_normal_force false", "constraints.min_normal_force", constraints={"min_normal_force": False})
scase("min_normal_force nan", "constraints.min_normal_force", constraints={"min_normal_force": "nan N"})
scase("multistart.starts 0", "multistart.starts", multistart={"starts": 0})
scase("multistart.starts -1", "multistart.starts", multistart={"starts": -1})
scase("multistart.starts false", "multistart.starts", multistart={"starts": False})
scase("multistart.starts 1e9", "multistart.starts: expected an integer from 1 to 10000", multistart={"starts": 10 ** 9})
scase("multistart.starts 2.5", "multistart.starts", multistart={"starts": 2.5})
scase("multistart.seed -1", "multistart.seed", multistart={"seed": -1})
scase("pareto.points 0", "pareto.points", pareto={"points": 0})
scase("max_iter 0", "max_iter", max_iter=0)
scase("unknown effect", "effects", effects=["bogus_effect"])
scase("study envelope step 0", "envelope.gamma", envelope={"gamma": {"start": "-80 deg", "stop": "80 deg", "step": "0 deg"}})
scase("study name with a space", "name: expected a name", name="a b")
scase("unknown sweep parameter", ("batch.sweep.preloud", "did you mean 'preload'"), command="study",
      batch={"sweep": {"preloud": ["100 N"]}})
scase("sweep of a design variable", "batch.sweep.d", command="study", batch={"sweep": {"d": ["50 mm"]}})
scase("sweep value nan", "batch.sweep.preload", command="study", batch={"sweep": {"preload": ["nan N"]}})
scase("sweep value in mm", "batch.sweep.preload[0]", command="study", batch={"sweep": {"preload": ["100 mm"]}})
scase("sweep value negative", ("bad_study.yaml: batch.sweep: at preload = -80 (SI) the variant is not valid:",
                               "roller_defaults.preload: expected a positive value"),
      command="study", batch={"sweep": {"preload": ["-80 N"]}})
scase("batch variant missing", "nope.yaml", command="study", batch={"variants": ["../variants/nope.yaml"]})
scase("batch.pareto 'yes'", "batch.pareto", command="study", batch={"pareto": "yes"})
case("study: missing study file", ("nope.yaml", "cannot read file"), cli("study", "{in}/nope.yaml", "--out", "{out}/s"),
     "study", "study YAML")
# command line
P = "{tmp}/work/studies/box_placement_kim.yaml"
for id, expect, args in [
    ("--starts 0", "--starts", ("--starts", "0")),          # was ignored (one start): cmd_optimise refuses it
    ("--starts -2", "--starts", ("--starts", "-2")),
    ("--starts abc", "argument --starts: invalid int value: 'abc'", ("--starts", "abc")),
    ("--starts 1.5", "argument --starts", ("--starts", "1.5")),
    ("--starts 1e9", "--starts: expected from 1 to 10000", ("--starts", "1000000000")),   # filled memory
    ("--json to a directory", ("--json", "is a directory"), ("--json", "{adir}")),
    ("--json under a file", ("--json", "not a folder"), ("--json", "{plain}/o.json")),
    ("--json in a missing folder", ("--json", "no folder"), ("--json", "{tmp}/nowhere/o.json")),
    ("--out is a file", ("--out", "is not a folder"), ("--out", "{plain}")),
    ("--out under a file", ("--out", "lies under"), ("--out", "{plain}/res")),
]:
    case(f"optimise: {id}", expect, cli("optimise", P, *args), "optimise", "command line")
case("optimise: no study", ("optimise", "study"), cli("optimise"), "optimise", "command line")
for id, expect, args in [
    ("--workers -1", "--workers", ("--workers", "-1")),
    ("--workers 0", "--workers", ("--workers", "0")),
    ("--workers abc", "argument --workers: invalid int value", ("--workers", "abc")),
    ("--scheduler not an address", "--scheduler", ("--scheduler", "not-an-address")),
    ("--scheduler empty", "--scheduler: empty", ("--scheduler", "")),    # cli.options: every empty value
    ("--out is a file", ("--out", "is not a folder"), ("--out", "{plain}")),
]:
    case(f"study: {id}", expect, cli("study", P, *args), "study", "command line")
# (cmd_study asks the scheduler before run_study creates the store's .lock and manifest.json)
case("study: --scheduler with nobody listening", ("--scheduler", "no Dask scheduler answered"),
     scheduler_nobody("study"), "study", "command line", slow=True)   # waits out the connect timeout

# ------------------------------------------------------------------------------------------------- export

case("export: missing variant", ("nope.yaml", "cannot read file"), with_variant("export", missing=True),
     "export", "variant YAML")
case("export: variant with an unknown field", ("bad.yaml", "rollers.D1.radus: unknown field"),
     with_variant("export", (D1 + ("radius",), DEL), (D1 + ("radus",), "40 mm")), "export", "variant YAML")
case("export: frame.distance < 0", ("bad.yaml", "frame.distance"),
     with_variant("export", (("frame",), {"side": "-z", "distance": "-200 mm"})), "export", "variant YAML")
for id, expect, args in [
    ("--gamma nan", "--gamma", ("--gamma", "nan")),
    ("--gamma 100", "--gamma: γ = 100°", ("--gamma", "100")),
    ("--gamma -95", "--gamma", ("--gamma=-95",)),
    ("--gamma inf", "--gamma", ("--gamma", "inf")),
    ("--gamma abc", "argument --gamma: invalid float value: 'abc'", ("--gamma", "abc")),
    ("--gamma '45 deg'", "argument --gamma", ("--gamma", "45 deg")),
    ("--out is a file", ("--out", "is not a folder"), ("--out", "{plain}")),
    ("--out under a file", ("--out", "lies under"), ("--out", "{plain}/cad")),
]:
    case(f"export: {id}", expect, cli("export", "{v}", *args), "export", "command line")

# ---------------------------------------------------------------------------------------------------- rig

case("rig: missing variant", ("nope.yaml", "cannot read file"), with_variant("rig", missing=True), "rig", "variant YAML")
case("rig: variant with wrong unit", ("bad.yaml", "rollers.D1.radius"), with_variant("rig", (D1 + ("radius",), "40 N")),
     "rig", "variant YAML")
case("rig: variant with an unknown effect", ("bad.yaml", "effects"), with_variant("rig", (("effects",), ["slip"])),
     "rig", "variant YAML")
R = ("rig", "{v}", "--out", "{out}/d.csv")
for id, expect, args in [
    ("--effects unknown", ("--effects", "did you mean 'drive_longitudinal_creep'"), ("--effects", "drive_longitudinal_crep")),
    ("--effects one unknown of two", ("--effects", "bogus"), ("--effects", "steering_lateral_creep,bogus")),
    ("--set without a dot", "--set", ("--set", "foo")),
    ("--set without a value", ("--set", "steering_lateral_creep.scale"), ("--set", "steering_lateral_creep.scale")),
    ("--set with an empty value", ("--set", "steering_lateral_creep.scale"), ("--set", "steering_lateral_creep.scale=")),
    ("--set '=1'", "--set", ("--set", "=1")),
    ("--set unknown parameter", ("--set", "no parameter 'scal'"), ("--set", "steering_lateral_creep.scal=1.2")),
    ("--set unknown effect", ("--set", "bogus"), ("--set", "bogus.x=1")),
    ("--set an effect that is off", ("--set", "rolling_resistance"), ("--set", "rolling_resistance.offset=0.1 mm")),
    ("--set -inf", ("--set", "steering_lateral_creep.scale"), ("--set", "steering_lateral_creep.scale=-inf")),
    ("--set wrong unit", ("--set", "steering_lateral_creep.scale"), ("--set", "steering_lateral_creep.scale=1 mm")),
    ("--set out of range", ("--set", "steering_lateral_creep.scale"), ("--set", "steering_lateral_creep.scale=100")),
    ("--set not a number", ("--set", "drive_longitudinal_creep.scale"), ("--set", "drive_longitudinal_creep.scale=big")),
    ("--noise without =", "--noise", ("--noise", "speed")),
    ("--noise unknown name", ("--noise", "did you mean 'speed'"), ("--noise", "sped=0.01")),
    ("--noise negative", ("--noise", "speed"), ("--noise", "speed=-0.01")),
    ("--noise nan", ("--noise", "torque"), ("--noise", "torque=nan N*m")),
    ("--noise wrong unit", ("--noise", "speed"), ("--noise", "speed=0.01 N")),
    ("--noise not a number", ("--noise", "axis"), ("--noise", "axis=wide")),
    ("--noise empty item", "--noise", ("--noise", "speed=0.01,,torque=0.1")),
    ("--replicates 0", "--replicates", ("--replicates", "0")),    # was ignored (1 replicate written)
    ("--replicates -1", "replicates", ("--replicates", "-1")),
    ("--replicates abc", "argument --replicates: invalid int value", ("--replicates", "abc")),
    ("--replicates 1e8", "--replicates: expected from 1 to 10000", ("--replicates", "100000000")),   # filled memory
    ("--seed -1", "seed", ("--seed", "-1")),
    ("--seed 1.5", "argument --seed", ("--seed", "1.5")),
]:
    case(f"rig: {id}", expect, cli(*R, *args), "rig", "command line")
for id, expect, out in [
    ("--out to a directory", ("--out", "is a directory"), "{adir}"),
    ("--out under a file", ("--out", "not a folder"), "{plain}/d.csv"),
    ("--out in a missing folder", ("--out", "no folder"), "{tmp}/nowhere/d.csv"),
]:
    case(f"rig: {id}", expect, cli("rig", "{v}", "--out", out), "rig", "command line")
case("rig: --protocol missing", ("nope.yaml", "cannot read file"), cli(*R, "--protocol", "{in}/nope.yaml"),
     "rig", "protocol YAML")
case("rig: --protocol is a directory", ("adir", "cannot read file"), cli(*R, "--protocol", "{adir}"),
     "rig", "protocol YAML")
case("rig: no --out", ("rig", "--out"), cli("rig", "{v}"), "rig", "command line")
case("optimise: --json is the calibration", ("--json", "is this command's input (calibration)"),
     cli("optimise", "{tmp}/work/studies/box_placement_kim.yaml", "--calibration", "{plain}", "--json", "{plain}"),
     "optimise", "command line")
case("rig: --out is the variant", ("--out", "existing_kim.yaml is this command's input (variant)"),
     cli("rig", "{v}", "--out", "{v}"), "rig", "command line")
case("diagnose: --json is the data", ("--json", "is this command's input (data)"),
     cli("diagnose", "{csv}", "--variant", "{v}", "--json", "{csv}"), "diagnose", "command line")
case("compare: --report is a variant", ("--report", "existing_kim.yaml is this command's input (variants)"),
     cli("compare", "{v}", "--report", "{v}"), "compare", "command line")


def pcase(id, expect, content):
    exp = (expect,) if isinstance(expect, str) else tuple(expect)
    case(f"rig --protocol: {id}", ("protocol.yaml",) + exp, protocol(content), "rig", "protocol YAML")


pcase("empty", "expected a YAML mapping", "")
pcase("not YAML", "not valid YAML", "gamma: [1, 2\nload: x\n")
pcase("a list", "expected a YAML mapping", ["gamma", "load"])
pcase("duplicate key", "duplicate key 'gamma'", "gamma: ['0 deg']\ngamma: ['10 deg']\n")
case("rig --protocol: NUL byte", ("protocol.yaml", "not valid YAML"), protocol("gamma: ['0 deg']\x00\n"),
     "rig", "protocol YAML")
pcase("non-UTF-8", "not UTF-8", b"# \xff\ngamma: ['0 deg']\n")
pcase("unknown key", ("gama", "did you mean 'gamma'"), {"gama": ["0 deg"]})
pcase("gamma in N", "gamma[0]", {"gamma": ["30 N"]})
pcase("gamma nan", "gamma[1]", {"gamma": ["0 deg", "nan deg"]})
pcase("gamma stop < start", "gamma", {"gamma": {"start": "80 deg", "stop": "-80 deg", "step": "10 deg"}})
pcase("gamma step 0", "gamma", {"gamma": {"start": "-80 deg", "stop": "80 deg", "step": "0 deg"}})
pcase("gamma range typo", ("stepp: unknown field", "did you mean 'step'"),
      {"gamma": {"start": "-80 deg", "stop": "80 deg", "stepp": "10 deg"}})
pcase("load in m", "load[0]", {"load": ["1 m"]})
pcase("load true", "load", {"load": [True]})
pcase("unknown load_kind", "load_kind", {"load_kind": "torque"})
pcase("motor_speed 0", "motor_speed", {"motor_speed": "0 rad/s"})
pcase("motor_speed in N", "motor_speed", {"motor_speed": "10 N"})
pcase("replicates 0", "replicates", {"replicates": 0})
pcase("replicates true", "replicates", {"replicates": True})

# ------------------------------------------------------------------------------ measured CSV: diagnose

TOO_FEW = HEADER + "".join(ROWS.splitlines(keepends=True)[:6])


def dcase(id, expect, content, *extra):
    exp = (expect,) if isinstance(expect, str) else tuple(expect)
    case(f"diagnose: {id}", ("data.csv",) + exp, diagnose(content, *extra), "diagnose", "measured CSV")


case("diagnose: CSV missing", ("nope.csv", "no such file"),
     cli("diagnose", "{in}/nope.csv", "--variant", "{v}", "--json", "{out}/r.json"), "diagnose", "measured CSV")
case("diagnose: CSV is a directory", ("adir", "cannot read file"),
     cli("diagnose", "{adir}", "--variant", "{v}", "--json", "{out}/r.json"), "diagnose", "measured CSV")
dcase("empty file", "not a readable CSV file", "")
dcase("header only", "no data rows under the header", HEADER)
dcase("missing column with suggestion", ("missing column 'omega_1'", "did you mean 'omega1'"),
      HEADER.replace("omega_1", "omega1") + ROWS)
dcase("missing column", "missing column 'tau_2'", HEADER.replace(",tau_2", "") + ROWS.replace(",0.5\n", "\n"))
dcase("semicolon-separated", "missing column", HEADER.replace(",", ";") + ROWS.replace(",", ";"))
dcase("non-numeric cell", ("line 23", "column 'tau_1'", "'heavy' is not a number"), HEADER + ROWS + "0,10,0,heavy,0.1\n")
dcase("empty cell", ("line 23", "column 'omega_2' is empty"), HEADER + ROWS + "0,10,,0.1,0.1\n")
dcase("inf cell", ("line 23", "column 'omega_2'", "finite"), HEADER + ROWS + "0,10,inf,0.1,0.1\n")
dcase("-inf cell", ("line 2", "column 'tau_1'", "finite"), HEADER + "0,10,0,-inf,0.1\n" + ROWS)
dcase("nan cell", ("line 23", "column 'tau_2'"), HEADER + ROWS + "0,10,0,0.1,nan\n")
dcase("motor at rest", ("line 23", "omega_1 is 0"), HEADER + ROWS + "20,0,0,0.1,0.1\n")
dcase("gamma outside the envelope", ("line 23", "gamma_cmd_deg = 85"), HEADER + ROWS + "85,10,100,0.1,0.1\n")
dcase("too few operating points", "6 operating points", TOO_FEW)
dcase("non-UTF-8", ("line 23", "not UTF-8"), (HEADER + ROWS).encode() + b"0,10,\xe9,1,1\n")
dcase("binary file", "not a readable CSV file (byte 0x89", b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256)))
dcase("NUL byte", ("line 3", "NUL byte"), HEADER + "0,10,0,0.1,0.1\n0,\x00,0,0,0\n")
dcase("a ragged row", "not a readable CSV file", HEADER + ROWS + "0,10,0,0.1,0.1,7,8,9\n")
dcase("a gamma_axis_deg of text", ("line 2", "column 'gamma_axis_deg'"),
      HEADER.replace("tau_2", "tau_2,gamma_axis_deg") + ROWS.replace("\n", ",x\n"))
case("diagnose: --variant missing", ("nope.yaml", "cannot read file"), with_variant("diagnose", missing=True),
     "diagnose", "variant YAML")
case("diagnose: --variant with a bad roller", ("bad.yaml", "rollers.D1.axle"),
     with_variant("diagnose", (D1 + ("axle",), "d2")), "diagnose", "variant YAML")
D = ("diagnose", "{csv}", "--variant", "{v}")
for id, expect, args in [
    ("no --variant", ("diagnose", "--variant"), ("diagnose", "{csv}")),
    ("--base unknown effect", ("--base", "did you mean 'drive_longitudinal_creep'"), D + ("--base", "drive_longitudinal_crep")),
    ("a candidate already in the base", ("--candidates: drive_longitudinal_creep is already in the base model",),
     D + ("--base", "drive_longitudinal_creep", "--candidates", "drive_longitudinal_creep")),   # tested nothing
    ("--base with an empty item and an unknown one", ("--base", "bogus"), D + ("--base", "drive_longitudinal_creep,,bogus")),
    ("--candidates unknown effect", ("--candidates", "bogus"), D + ("--candidates", "rolling_resistance,bogus")),
    ("--json to a directory", ("--json", "is a directory"), D + ("--json", "{adir}")),
    ("--json under a file", ("--json", "not a folder"), D + ("--json", "{plain}/r.json")),
    ("--plots is a file", ("--plots", "is not a folder"), D + ("--plots", "{plain}")),
    ("--plots under a file", ("--plots", "lies under"), D + ("--plots", "{plain}/plots")),
]:
    case(f"diagnose: {id}", expect, cli(*args), "diagnose", "command line")

# -------------------------------------------------------------------------------------------------- resteer

T = ("resteer", "--variant", "{v}", "--json", "{out}/r.json")
for id, expect, args in [
    ("--load inf", "--load", ("--load", "inf N*m")),
    ("--load outside the envelope", "--load: τ⊥ = 2 N·m is outside", ("--load", "2 N*m")),
    ("--load in m", "--load", ("--load", "1 m")),
    ("--load not a number", "--load", ("--load", "abc")),
    ("--ratios with an empty item", "--ratios", ("--ratios", "1,,2")),
    ("--ratios not numbers", "--ratios", ("--ratios", "a,b")),
    ("--ratios 0", "--ratios", ("--ratios", "0")),
    ("--ratios negative", "--ratios", ("--ratios", "0.5,-1")),
    ("--ratios inf", "--ratios", ("--ratios", "1,inf")),
    ("--ratios beyond the envelope", ("--ratios: ω2/ω1 = 100 needs γ = 89.4 deg by the ideal law",
                                      "expected ratios up to 5.67"), ("--ratios", "1,100")),
    ("--effects unknown", ("--effects", "bogus"), ("--effects", "bogus")),
    ("--truth-effects unknown", ("--truth-effects", "did you mean 'drive_spin_creep'"), ("--truth-effects", "drive_spin_crep")),
    ("--truth-set malformed", "--truth-set", ("--truth-effects", "drive_spin_creep", "--truth-set", "garbage")),
    ("--truth-set unknown parameter", ("--truth-set", "no parameter 'scal'"),
     ("--truth-effects", "drive_spin_creep", "--truth-set", "drive_spin_creep.scale=4", "--truth-set", "drive_spin_creep.scal=4")),
    ("--truth-set without --truth-effects", ("--truth-set", "--truth-effects"),     # was silently ignored
     ("--truth-set", "drive_spin_creep.scale=4")),
    ("data file missing", ("nope.csv", "no such file"), ("{in}/nope.csv",)),
    ("--json to a directory", ("--json", "is a directory"), ("--json", "{adir}")),
    ("--plots is a file", ("--plots", "is not a folder"), ("--plots", "{plain}")),
]:
    case(f"resteer: {id}", expect, cli(*T, *args), "resteer", "command line")
case("resteer: data header only", ("data.csv", "no data rows"),
     lambda env: cli(*T, str(_write(env.inp / "data.csv", HEADER)))(env), "resteer", "measured CSV")
case("resteer: data file non-numeric", ("data.csv", "line 2", "column 'omega_1'"),
     lambda env: cli(*T, str(_write(env.inp / "data.csv", HEADER + "0,fast,0,0,0\n" + ROWS)))(env), "resteer", "measured CSV")
case("resteer: --variant missing", ("nope.yaml", "cannot read file"), with_variant("resteer", missing=True),
     "resteer", "variant YAML")
case("resteer: variant with a bad envelope", ("bad.yaml", "envelope.load"),
     with_variant("resteer", (ENV_L + ("step",), "0 N*m")), "resteer", "variant YAML")
case("resteer: no --variant", ("resteer", "--variant"), cli("resteer", "--load", "1 N*m"), "resteer", "command line")

TT = ("resteer", "{v}", "--table", "{out}/t.csv")          # the controller table (issue 27)
for id, expect, args in [
    ("--table-ratios START ≥ STOP", ("--table-ratios", "START < STOP"), ("--table-ratios", "2.5:0.4:5")),
    ("--table-ratios COUNT 1", ("--table-ratios", "2 ≤ COUNT"), ("--table-ratios", "0.4:2.5:1")),
    ("--table-ratios COUNT not whole", ("--table-ratios", "COUNT", "'x'"), ("--table-ratios", "0.4:2.5:x")),
    ("--table-ratios two colons only", ("--table-ratios", "START:STOP:COUNT"), ("--table-ratios", "0.4:2.5")),
    ("--table-ratios not numbers", ("--table-ratios", "expected numbers"), ("--table-ratios", "a,b")),
    ("--table-ratios not increasing", ("--table-ratios", "increasing"), ("--table-ratios", "1,1")),
    ("--table-ratios one value", ("--table-ratios", "2 to 1001"), ("--table-ratios", "1")),
    ("--table-ratios inf", ("--table-ratios", "finite"), ("--table-ratios", "1,inf")),
    ("--table-ratios nan stop", ("--table-ratios", "finite"), ("--table-ratios", "0.4:nan:5")),
    ("--table-ratios beyond the envelope", ("--table-ratios: ω2/ω1 = 100 needs γ = 89.4 deg",), ("--table-ratios", "1,100")),
    ("--table-loads outside the envelope", ("--table-loads: τ⊥ = -2 N·m is outside",),
     ("--table-loads", "-2 N*m:1 N*m:4")),
    ("--table-loads in m", "--table-loads", ("--table-loads", "0,1 m")),
    ("--table-loads not increasing", ("--table-loads", "increasing"), ("--table-loads", "1,0")),
    ("a grid past what one evaluation holds", ("--table-ratios × --table-loads", "scan points"),
     ("--table-ratios", "0.4:2.5:1001", "--table-loads", "-1:1:1001")),
    ("--load with --table", ("--load", "--table-loads"), ("--load", "1 N*m")),
    ("--json with --table", ("--json", "with --table"), ("--json", "{out}/r.json")),
    ("--table to a directory", ("--table", "is a directory"), ("--table", "{adir}")),
    ("--table is the variant", ("--table", "this command's input"), ("--table", "{v}")),
]:
    case(f"resteer: {id}", expect, cli(*TT, *args), "resteer", "command line")
case("resteer: --table-ratios without --table", ("--table-ratios", "expected --table"),
     cli("resteer", "{v}", "--table-ratios", "0.4:2.5:5"), "resteer", "command line")
case("resteer: a variant twice", ("existing_kim.yaml is a variant file and --variant names another",),
     cli("resteer", "{v}", "--variant", "{v}", "--table", "{out}/t.csv"), "resteer", "command line")

# ------------------------------------------------------------------------------------------------- capacity

for id, expect, args in [
    ("--safety 0", ("--safety", "at least 1"), ("--safety", "0")),
    ("--safety below 1", ("--safety", "at least 1", "got 0.5"), ("--safety", "0.5")),
    ("--safety negative", ("--safety", "at least 1"), ("--safety", "-1.5")),
    ("--safety nan", ("--safety", "finite"), ("--safety", "nan")),
    ("--safety inf", ("--safety", "finite"), ("--safety", "inf")),
    ("--safety not a number", "argument --safety: invalid float value", ("--safety", "1.5x")),
    ("--json to a directory", ("--json", "is a directory"), ("--json", "{adir}")),
    ("--plots is a file", ("--plots", "is not a folder"), ("--plots", "{plain}")),
    ("--json is the variant", ("--json", "this command's input"), ("--json", "{v}")),
    ("--max-slip 0", ("--max-slip", "expected more than 0 deg"), ("--max-slip", "0 deg")),
    ("--max-slip negative", ("--max-slip", "expected more than 0 deg"), ("--max-slip=-2deg",)),
    ("--max-slip past 90°", ("--max-slip", "expected at most 90 deg"), ("--max-slip", "91 deg")),
    ("--max-slip plain number", ("--max-slip", "at most 90 deg", "did you mean '2 deg'"), ("--max-slip", "2")),
    ("--max-slip not an angle", ("--max-slip", "expected an angle", "2 mm"), ("--max-slip", "2 mm")),
    ("--max-slip nan", ("--max-slip", "finite"), ("--max-slip", "nan deg")),
    ("--max-slip not a number", ("--max-slip", "expected an angle"), ("--max-slip", "two degrees")),
    ("--samples too few", ("--samples", "expected 0 (first order only) or 20 to"), ("--samples", "5")),
    ("--samples negative", ("--samples", "expected 0"), ("--samples", "-1")),
    ("--samples not a number", "argument --samples: invalid int value", ("--samples", "many")),
]:
    case(f"capacity: {id}", expect, cli("capacity", "{v}", "--json", "{out}/c.json", *args), "capacity", "command line")
case("capacity: missing file", ("nope.yaml", "cannot read file"), cli("capacity", "{in}/nope.yaml"), "capacity",
     "variant YAML")
case("capacity: variant with non-finite preload", ("bad.yaml", "rollers.D1.preload"),
     lambda env: ["capacity", str(bad_variant(env, [(D1 + ("preload",), "inf N")]))], "capacity", "variant YAML")

# ------------------------------------------------------------------------------------------------ selfcheck

for id, expect, args in [
    ("--only matching nothing", ("--only", "zzz"), ("--matrices", "independent", "--only", "zzz")),
    ("--only matching nothing (rig matrix)", ("--only", "nothing-like-this"), ("--quick", "--only", "nothing-like-this")),
    ("--matrices unknown", ("--matrices", "unknown matrix 'bogus'"), ("--matrices", "bogus")),
    ("--matrices one unknown of two", ("--matrices", "indpendent"), ("--matrices", "rig,indpendent")),
    ("--workers -1", "--workers", ("--matrices", "independent", "--workers", "-1")),
    ("--workers 0", "--workers", ("--matrices", "independent", "--workers", "0")),
    ("--seeds 0", "--seeds", ("--seeds", "0")),          # was accepted: a full matrix run without nulls
    ("--seeds -1", "--seeds", ("--seeds", "-1")),
    ("--seeds abc", "argument --seeds: invalid int value", ("--seeds", "abc")),
    ("--json to a directory", ("--json", "is a directory"), ("--json", "{adir}")),
    ("--json under a file", ("--json", "not a folder"), ("--json", "{plain}/s.json")),
    ("--scheduler not an address", "--scheduler", ("--matrices", "independent", "--quick", "--scheduler", "nowhere")),
]:
    case(f"selfcheck: {id}", expect, cli("selfcheck", *args), "selfcheck", "command line")
case("selfcheck: --scheduler with nobody listening", ("--scheduler", "no Dask scheduler answered"),
     scheduler_nobody("selfcheck"), "selfcheck", "command line", slow=True)
case("selfcheck: --variant missing", ("nope.yaml", "cannot read file"), with_variant("selfcheck", missing=True),
     "selfcheck", "variant YAML")
case("selfcheck: --variant with non-finite preload", ("bad.yaml", "rollers.D1.preload"),
     with_variant("selfcheck", (D1 + ("preload",), "inf N")), "selfcheck", "variant YAML")


# ------------------------------------------------------------------ a fresh sample of hostile inputs (issue 25)
# Units of the wrong kind: pint holds angles dimensionless, so '10 %' became 0.1 rad (5.73°) and '45 deg' a
# friction of 0.785; '10 Hz' became 10 rad/s (it is 62.8). Loads beyond anything the variant's contacts can
# carry ('-1000..1000' meant in N·mm). Grids, workers and duty cycles beyond what the machine or the model has.

WRONG_KIND = [
    ("angle in %", "envelope.gamma.step", ENV_G + ("step",), "10 %"),
    ("angle as a length ratio", "envelope.gamma.stop", ENV_G + ("stop",), "1.4 m/m"),
    ("angle in ppm", "envelope.gamma.start", ENV_G + ("start",), "-1e6 ppm"),
    ("contact polar angle in %", "rollers.D1.contact.polar", D1 + ("contact",), {"polar": "50 %", "azimuth": "90 deg"}),
    ("contact azimuth as a length ratio", "rollers.D1.contact.azimuth", D1 + ("contact",),
     {"polar": "90 deg", "azimuth": "1570 mm/m"}),
    ("steering offset in %", "effect_parameters.steering_offset.offset", EP, {"steering_offset": {"offset": "5 %"}}),
    ("friction in degrees", "pairs.0.friction", ("pairs", 0, "friction"), "45 deg"),
    ("Poisson's ratio in rad", "urethane_82A.poisson_ratio", M82 + ("poisson_ratio",), "0.48 rad"),
    ("coupling ratio in turns", "rollers.D1.ratio", D1 + ("ratio",), "1 turn"),
    ("motor speed in Hz", "envelope.motor_speed", ("envelope", "motor_speed"), "10 Hz"),
    ("motor speed in 1/min", "envelope.motor_speed", ("envelope", "motor_speed"), "600 1/min"),
]
for id, expect, path, value in WRONG_KIND:
    vcase(f"wrong kind: {id}", expect, (path, value))
vcase("wrong kind: a parameter in % as a polar angle", ("rollers.D1.contact.polar", "parameter tilt"),
      (("parameters", "tilt"), "100 %"), (D1 + ("contact",), {"polar": "= tilt", "azimuth": "90 deg"}))
vcase("load range meant in N·mm", "envelope.load", (ENV_L, {"start": -1000, "stop": 1000, "step": 100}))
vcase("load of 300 N·m on 100 N preloads", "envelope.load.stop", (ENV_L + ("stop",), "300 N*m"))
vcase("an envelope of 9e9 points", "envelope", (ENV_G + ("step",), "0.0017 deg"), (ENV_L + ("step",), "2.1e-5 N*m"))
pcase("gamma in %", "gamma[0]", {"gamma": ["10 %"]})
pcase("load beyond the contacts' traction", "load[0]", {"load": ["500 N*m"]})
case("rig: --noise axis in %", "--noise", cli("rig", "{v}", "--noise", "axis=0.05 %", "--out", "{out}/d.csv"),
     "rig", "command line")
case("rig: --noise speed in Hz", "--noise", cli("rig", "{v}", "--noise", "speed=0.01 Hz", "--out", "{out}/d.csv"),
     "rig", "command line")
case("resteer: --load in %", "--load", cli(*T, "--load", "10 %"), "resteer", "command line")
DUTY = {"kind": "power_loss"}
scase("duty-cycle point at γ = 120°", "objective.duty_cycle[0].gamma",
      objective=DUTY | {"duty_cycle": [{"gamma": "120 deg", "load": "0.5 N*m"}]})
scase("duty-cycle point at γ = -90°", "objective.duty_cycle[1].gamma",
      objective=DUTY | {"duty_cycle": [{"gamma": "30 deg", "load": "0.5 N*m"}, {"gamma": "-90 deg", "load": "0"}]})
scase("duty-cycle γ in %", "objective.duty_cycle[0].gamma", objective=DUTY | {"duty_cycle": [{"gamma": "50 %", "load": 0.5}]})
scase("duty-cycle load beyond the contacts", "objective.duty_cycle[0].load",
      objective=DUTY | {"duty_cycle": [{"gamma": "30 deg", "load": "500 N*m"}]})
scase("study envelope load meant in N·mm", "envelope.load", envelope=Whole(
    {"gamma": {"start": "-60 deg", "stop": "60 deg", "step": "30 deg"}, "load": {"start": -1000, "stop": 1000, "step": 500}}))
case("study: --workers 100000", ("--workers", "100000"),
     cli("study", "{tmp}/work/studies/box_placement_kim.yaml", "--out", "{out}/store", "--workers", "100000"),
     "study", "command line")
case("selfcheck: --workers 100000", ("--workers", "100000"),
     cli("selfcheck", "--matrices", "independent", "--quick", "--workers", "100000", "--json", "{out}/s.json"),
     "selfcheck", "command line")
case("export: --gamma 90", "--gamma", cli("export", "{v}", "--gamma", "90", "--out", "{out}/cad"), "export",
     "command line")
case("selfcheck: --seeds 100000000", "--seeds", cli("selfcheck", "--seeds", "100000000", "--json", "{out}/s.json"),
     "selfcheck", "command line")
case("rig: --replicates 10000 (1.87 million rows)", "replicates",
     cli("rig", "{v}", "--replicates", "10000", "--out", "{out}/d.csv"), "rig", "command line")
pcase("1e10 operating points", "protocol.yaml", {"gamma": {"start": "-80 deg", "stop": "80 deg", "step": "0.0017 deg"},
                                                 "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "2.1e-5 N*m"}})


# --------------------------------------------------------------------------------------------------- runner

def snapshot(folder: Path) -> dict:
    """Every path under `folder`: its type and, for files, size and content hash (links: their target)."""
    tree = {}
    for dirpath, dirnames, filenames in os.walk(folder):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            rel = str(p.relative_to(folder))
            if p.is_symlink():
                tree[rel] = ("link", os.readlink(p))
            elif p.is_dir():
                tree[rel] = ("dir",)
            else:
                tree[rel] = ("file", hashlib.sha1(p.read_bytes()).hexdigest())
    return tree


def check_promise(rc, out: str, err: str, expect, before: dict, after: dict):
    assert "Traceback" not in out and "Traceback" not in err, err or out
    assert rc == 2, f"exit status {rc}; stderr: {err!r}"
    lines = err.split("\n")
    assert len(lines) == 2 and lines[1] == "" and lines[0].strip(), f"expected one line on stderr, got {err!r}"
    line = lines[0]
    assert line.startswith("cvtdesign: error: ") or (line.startswith("cvtdesign ") and ": error: " in line), line
    for e in (expect,) if isinstance(expect, str) else expect:
        assert e in line, f"{e!r} not in {line!r}"
    new = sorted(set(after) - set(before))
    gone = sorted(set(before) - set(after))
    changed = sorted(k for k in set(before) & set(after) if before[k] != after[k])
    assert not (new or gone or changed), f"files new {new}, removed {gone}, changed {changed}"


MAX_SECONDS = 15     # a refusal comes at once (an unreachable scheduler: after its 5 s connect timeout)


@contextlib.contextmanager
def deadline(seconds: int):
    """Fail a case that is not refused at all (an accepted input may start hours of work): a TimeoutError
    in the main thread after `seconds`."""
    def expire(signum, frame):
        raise TimeoutError(f"still running after {seconds} s: the input was not refused")
    old = signal.signal(signal.SIGALRM, expire)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


@pytest.mark.parametrize("build, expect", CASES)
def test_bad_input(build, expect, tmp_path, capfd, monkeypatch):
    seconds = run_and_check(build, expect, tmp_path, capfd, monkeypatch, 4 * MAX_SECONDS)
    assert seconds < MAX_SECONDS, f"refused only after {seconds:.1f} s"


def run_and_check(build, expect, tmp_path, capfd, monkeypatch, limit: int) -> float:
    """Run the command `build` makes in a fresh environment (the working folder inside it, so that relative
    defaults land in the snapshot) within `limit` seconds, check the promise, and return how long it took."""
    env = make_env(tmp_path)
    monkeypatch.chdir(env.work)
    argv = build(env)
    before = snapshot(tmp_path)
    capfd.readouterr()
    t0 = time.perf_counter()
    try:
        with deadline(limit):
            rc = main(argv)
    except SystemExit as e:              # argparse's errors
        rc = e.code
    seconds = time.perf_counter() - t0
    out, err = capfd.readouterr()
    check_promise(rc, out, err, expect, before, snapshot(tmp_path))
    return seconds


def test_an_alias_error_names_the_file_once(tmp_path, capsys):
    """A YAML file whose aliases refer to themselves: one line naming the file once (the InputError raised
    inside the reader was caught as a ValueError and wrapped again: 'x.yaml: not valid YAML: x.yaml: ...')."""
    f = _write(tmp_path / "alias.yaml", "a: &a [*a]\n")
    assert main(["compare", str(f), "--out", str(tmp_path / "p")]) == 2
    err = capsys.readouterr().err
    assert err.count(str(f)) == 1 and "aliases" in err and "not valid YAML" not in err, err


def test_table_covers_every_command_and_file_type():
    commands = {c for c, _ in COMMAND_OF.values()}
    kinds = {k for _, k in COMMAND_OF.values()}
    assert {"compare", "capacity", "optimise", "study", "export", "rig", "diagnose", "resteer", "selfcheck"} <= commands
    assert {"variant YAML", "study YAML", "protocol YAML", "measured CSV", "command line"} <= kinds
    assert len(CASES) >= 150


# ------------------------------------------------------------------------------ the console script itself

def _entry_point() -> list[str]:
    script = Path(sys.executable).parent / "cvtdesign"
    return [str(script)] if script.exists() else [sys.executable, "-m", "cvtdesign"]


SUBPROCESS = [
    pytest.param(cli("compare", "{in}/nope.yaml"), ("nope.yaml", "cannot read file"), id="compare missing file"),
    pytest.param(cli("rig", "{v}", "--replicates", "0", "--out", "{out}/d.csv"), "--replicates", id="rig --replicates 0"),
    pytest.param(cli("export", "{v}", "--gamma", "abc"), "argument --gamma: invalid float value", id="export --gamma abc"),
    pytest.param(diagnose(HEADER), ("data.csv", "no data rows"), id="diagnose header only"),
    pytest.param(optimise(constraints={"traction_margin": 1}), "constraints.traction_margin", id="optimise traction_margin 1"),
]


@pytest.mark.slow
@pytest.mark.parametrize("build, expect", SUBPROCESS)
def test_console_script_bad_input(build, expect, tmp_path):
    env = make_env(tmp_path)
    argv = build(env)
    before = snapshot(tmp_path)
    proc = subprocess.run(_entry_point() + argv, cwd=env.work, capture_output=True, text=True, timeout=120)
    check_promise(proc.returncode, proc.stdout, proc.stderr, expect, before, snapshot(tmp_path))
