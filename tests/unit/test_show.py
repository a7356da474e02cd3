"""`cvtdesign show`: the ideal law, the roller table and the layout drawing, before anything is solved."""
import contextlib
import io
import re
import sys
from pathlib import Path

import numpy as np
import pytest

from cvtdesign.core.geometry import steering_angle
from cvtdesign.cli import main
from cvtdesign.core.geometry import kim_gamma_from_phi
from cvtdesign.io.plots import layout_scene
from cvtdesign.io.variant import load_variant

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT / "tests") not in sys.path:
    sys.path.insert(0, str(ROOT / "tests"))

from layout_transforms import axis_angle_matrix, dump, read, rotate

VARIANTS = sorted((ROOT / "variants").glob("*.yaml"))
PNG = b"\x89PNG\r\n\x1a\n"
LAW = re.compile(r"(ω2/ω1 = [^;]*?)\s*(;|$)")


def law_of(out: str) -> str:
    return next(LAW.search(line).group(1) for line in out.splitlines() if line.startswith("ideal law: "))


@pytest.fixture(scope="module")
def compare_laws(tmp_path_factory):
    """{variant name: the ideal law `cvtdesign compare` prints for it}."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["compare", *map(str, VARIANTS), "--out", str(tmp_path_factory.mktemp("compare")), "--as-written"]) == 0
    laws = {}
    for line in out.getvalue().splitlines():
        name, _, rest = line.partition(": ")
        if rest.startswith("ω2/ω1 = "):
            laws[name] = LAW.search(rest).group(1)
    assert set(laws) == {p.stem for p in VARIANTS}
    return laws


@pytest.mark.parametrize("variant", VARIANTS, ids=lambda p: p.stem)
def test_show_each_shipped_variant(variant, compare_laws, cli, tmp_path):
    code, out, err = cli("show", variant, "--out", tmp_path)
    assert code == 0 and err == ""
    png = tmp_path / f"{variant.stem}_layout.png"
    assert png.read_bytes()[:8] == PNG and png.stat().st_size > 50_000
    assert [p.name for p in tmp_path.iterdir()] == [png.name]        # nothing else, no temporary file left
    assert law_of(out) == compare_laws[variant.stem]
    for r in load_variant(variant).rollers:                           # one table row per roller, radius in mm
        row = next(line for line in out.splitlines() if re.match(rf"│ {re.escape(r.name)}\s+│", line))
        assert f" {1000 * r.radius:.4g} " in row and f" {r.role} " in row


def test_laws_and_table_values(cli, tmp_path):
    laws = {}
    for name in ("existing", "unequal"):
        laws[name] = law_of(cli("show", ROOT / f"variants/{name}.yaml", "--out", tmp_path)[1])
    assert laws == {"existing": "ω2/ω1 = 1 · tan γ", "unequal": "ω2/ω1 = 0.6667 · tan γ"}   # k = r1/r2 (Kim eq 8)
    code, out, _ = cli("show", ROOT / "variants/existing.yaml", "--out", tmp_path)
    assert code == 0
    rows = {line.split("│")[1].strip(): line for line in out.splitlines() if line.startswith("│")}
    assert "d2 (-0.7071, 0.7071, 0)" in rows["D1"] and "-d1 (-0.7071, -0.7071, 0)" in rows["D1"]
    assert "about c2 (0, -0.7071, -0.7071), sign -1" in rows["S2"] and " 38 " in rows["S2"] and " 100 " in rows["S2"]


@pytest.mark.parametrize("name, gamma", [("existing", 30.0), ("existing", -55.0), ("box", 40.0)])
def test_forks_at_the_commanded_gamma(name, gamma, cli, tmp_path):
    """The printed φ realises γ (Kim eq 5 for the existing CVT, φ = γ for the box CVT), and every steered
    roller in the drawing rolls about the commanded axis u(γ) without lateral slip: (n × a)·u = 0."""
    code, out, _ = cli("show", ROOT / f"variants/{name}.yaml", "--gamma", gamma, "--out", tmp_path)
    assert code == 0
    phi = float(re.search(r"steering angle φ = (-?[\d.]+)°", out).group(1))
    expected = np.degrees(kim_gamma_from_phi(np.radians(phi))) if name == "existing" else phi
    assert (expected - gamma + 90) % 180 - 90 == pytest.approx(0, abs=2e-3)    # an axis is a line: mod 180°
    layout = load_variant(ROOT / f"variants/{name}.yaml")
    scene = layout_scene(layout, steering_angle(layout, np.radians(gamma)), np.radians(gamma))
    steered = [r for r in scene["rollers"] if r["fork"] is not None]
    assert steered and all(abs(np.cross(r["normal"], r["axle"]) @ scene["command"]) < 1e-8 for r in steered)
    assert all(np.linalg.norm(r["centre"]) == pytest.approx(1000 * float(layout.sphere_radius) + r["radius"])
               for r in scene["rollers"])


def test_rotated_copy_prints_the_same_law(cli, tmp_path):
    law = law_of(cli("show", ROOT / "variants/unequal.yaml", "--out", tmp_path / "a")[1])
    turned = dump(rotate(read("unequal"), axis_angle_matrix([1.0, 2.0, 3.0], 0.7)), tmp_path / "unequal.yaml")
    code, out, _ = cli("show", turned, "--gamma", 20, "--out", tmp_path / "b")
    assert code == 0 and law_of(out) == law == "ω2/ω1 = 0.6667 · tan γ"
    assert (tmp_path / "b" / "unequal_layout.png").read_bytes()[:8] == PNG


def test_bad_file_is_one_line_and_writes_nothing(cli, make_variant, tmp_path):
    bad = make_variant("existing", lambda d: d["rollers"]["D1"].update(radius="forty mm"), file="bad")
    code, out, err = cli("show", bad, "--out", tmp_path / "out")
    assert code == 2 and out == ""
    assert len(err.splitlines()) == 1 and err.startswith(f"cvtdesign: error: {bad}: rollers.D1.radius")
    assert "Traceback" not in err and not (tmp_path / "out").exists()


def test_gamma_outside_the_envelope_is_refused(cli, tmp_path):
    code, _, err = cli("show", ROOT / "variants/existing.yaml", "--gamma", 95, "--out", tmp_path / "out")
    assert code == 2 and len(err.splitlines()) == 1 and "--gamma" in err and not (tmp_path / "out").exists()
