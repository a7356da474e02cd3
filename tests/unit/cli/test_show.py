"""`cvtdesign show`: the ideal law, the roller table and the layout drawing, before anything is solved."""
import contextlib
import io
import re

import numpy as np
import pytest

from conftest import ROOT
from layout_transforms import axis_angle_matrix, dump, read, rotate
from kim_closed_forms import kim_gamma_from_phi  # tests/validation is on sys.path (tests/conftest.py)
from cvtdesign.core.geometry import KIM_FRAME, steering_angle
from cvtdesign.cli import main
from cvtdesign.io.plots.layout import layout_scene
from cvtdesign.io.variant import load_variant

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


@pytest.mark.slow
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


@pytest.mark.slow
def test_laws_and_table_values(cli, tmp_path):
    laws = {}
    for name in ("existing_kim", "unequal_kim"):
        laws[name] = law_of(cli("show", ROOT / f"variants/{name}.yaml", "--out", tmp_path)[1])
    assert laws == {"existing_kim": "ω2/ω1 = 1 · tan γ", "unequal_kim": "ω2/ω1 = 0.6667 · tan γ"}   # k = r1/r2 (Kim eq 8)
    code, out, _ = cli("show", ROOT / "variants/existing_kim.yaml", "--out", tmp_path)
    assert code == 0
    rows = {line.split("│")[1].strip(): line for line in out.splitlines() if line.startswith("│")}
    assert "d2 (-0.7071, 0.7071, 0)" in rows["D1"] and "-d1 (-0.7071, -0.7071, 0)" in rows["D1"]
    assert "about c2 (0, -0.7071, -0.7071), ratio -1" in rows["S2"] and " 38 " in rows["S2"] and " 100 " in rows["S2"]


@pytest.mark.parametrize("name, gamma", [("existing_kim", 30.0), ("existing_kim", -55.0), ("box_kim", 40.0)])
def test_forks_at_the_commanded_gamma(name, gamma, cli, tmp_path):
    """The printed φ realises γ (Kim eq 5 for the existing CVT, φ = γ for the box CVT), and every steered
    roller in the drawing rolls about the commanded axis u(γ) without lateral slip: (n × a)·u = 0."""
    code, out, _ = cli("show", ROOT / f"variants/{name}.yaml", "--gamma", gamma, "--out", tmp_path)
    assert code == 0
    phi = float(re.search(r"steering angle φ = (-?[\d.]+)°", out).group(1))
    expected = np.degrees(kim_gamma_from_phi(np.radians(phi))) if name == "existing_kim" else phi
    assert (expected - gamma + 90) % 180 - 90 == pytest.approx(0, abs=2e-3)    # an axis is a line: mod 180°
    layout = load_variant(ROOT / f"variants/{name}.yaml")
    scene = layout_scene(layout, steering_angle(layout, np.radians(gamma)), np.radians(gamma))
    steered = [r for r in scene["rollers"] if r["fork"] is not None]
    assert steered and all(abs(np.cross(r["normal"], r["axle"]) @ scene["command"]) < 1e-8 for r in steered)
    assert all(np.linalg.norm(r["centre"]) == pytest.approx(1000 * float(layout.sphere_radius) + r["radius"])
               for r in scene["rollers"])


@pytest.mark.slow
def test_rotated_copy_prints_the_same_law(cli, tmp_path):
    law = law_of(cli("show", ROOT / "variants/unequal_kim.yaml", "--out", tmp_path / "a")[1])
    turned = dump(rotate(read("unequal_kim"), axis_angle_matrix([1.0, 2.0, 3.0], 0.7)), tmp_path / "unequal_kim.yaml")
    code, out, _ = cli("show", turned, "--gamma", 20, "--out", tmp_path / "b")
    assert code == 0 and law_of(out) == law == "ω2/ω1 = 0.6667 · tan γ"
    assert (tmp_path / "b" / "unequal_kim_layout_gamma20.png").read_bytes()[:8] == PNG


# ------------------------------------------------------------------ a drawing a design review can use (issue 28)

from figure_checks import captured, text_problems  # noqa: E402

from cvtdesign.io.plots import layout as layout_drawing  # noqa: E402


def drawn(monkeypatch, cli, tmp_path, variant, *extra):
    """`show`'s figure (the Figure object, once written) and what the command printed."""
    figures = captured(monkeypatch, layout_drawing)
    code, out, err = cli("show", variant, "--out", tmp_path, *extra)
    assert code == 0 and err == ""
    return figures[-1], out


def view_labels(fig, title: str) -> dict:
    """{first line of a label: its anchor (x, y) [mm]} of the orthographic view titled `title`."""
    ax = next(a for a in fig.axes if a.get_title().startswith(title))
    return {t.get_text().split("\n")[0]: np.asarray(t.xy, float) for t in ax.texts if hasattr(t, "xy")}, ax


@pytest.mark.slow
@pytest.mark.parametrize("name", ["existing_kim", "box_kim", "unequal_kim"])
def test_labels_name_each_roller_its_shaft_and_fork_and_sit_on_it(name, monkeypatch, cli, tmp_path):
    """Kim's top view labelled 'shaft 1' beside D2 and 'fork (S2)' inside S1. Now each roller's label (its
    name, role, and the motor or brake shaft or the fork it is on) is anchored at that roller and no other,
    in every view; no text overlaps another or leaves the canvas."""
    fig, _ = drawn(monkeypatch, cli, tmp_path, ROOT / f"variants/{name}.yaml")
    assert text_problems(fig) == []
    layout = load_variant(ROOT / f"variants/{name}.yaml")
    scene = layout_scene(layout, steering_angle(layout, np.radians(45)), np.radians(45))
    forks = {n: k + 1 for k, f in enumerate(layout.forks) for n in f}
    for title, i, j, _, _ in layout_drawing.VIEWS:
        labels, ax = view_labels(fig, title)
        texts = {t.get_text().split("\n")[0]: t.get_text() for t in ax.texts}
        for r in scene["rollers"]:
            at = r["centre"] + 1.25 * r["radius"] * r["normal"]
            assert np.allclose(labels[r["name"]], at[[i, j]])
            expected = {1: "motor shaft 1", 2: "brake shaft 2"}.get(r["shaft"]) or f"fork {forks[r['name']]}"
            assert texts[r["name"]] == f"{r['name']}\n{r['role']} · {expected}"


def test_shafts_drawn_through_their_rollers_and_forks_out_through_theirs(existing_layout):
    """The motor and brake shafts are drawn along each of their rollers' axles through the roller (not the
    sphere's axis e1 through the centre); each fork's axis points from the centre towards its own rollers."""
    scene = layout_scene(existing_layout, steering_angle(existing_layout, np.radians(45)), np.radians(45))
    for r in scene["rollers"]:
        line = layout_drawing.shaft_line(r)
        if r["role"] == "steering":
            assert line is None
            continue
        assert np.allclose(line.mean(axis=0), r["centre"]) and abs(abs(np.diff(line, axis=0)[0] @ r["axle"])
                                                                     - np.linalg.norm(np.diff(line, axis=0))) < 1e-9
    for f in scene["forks"]:
        own = [r for r in scene["rollers"] if r["name"] in f["rollers"]]
        assert [r["name"] for r in own] == [f"S{f['index']}"]
        assert all(r["centre"] @ f["axis"] > 0.9 * np.linalg.norm(r["centre"]) for r in own)


def test_frame_vectors_only_where_the_file_names_them(monkeypatch, cli, tmp_path):
    """Kim's d1…c3 mean something only on a layout written in them: existing names d1 d2 c1 c2, box d1 d2;
    a rotated copy of unequal, written in numbers, gets none (they were drawn on it all the same)."""
    assert load_variant(ROOT / "variants/existing_kim.yaml").kim_vectors == ("d1", "d2", "c1", "c2")
    assert load_variant(ROOT / "variants/box_kim.yaml").kim_vectors == ("d1", "d2")
    turned = dump(rotate(read("unequal_kim"), axis_angle_matrix([1.0, 2.0, 3.0], 0.7)), tmp_path / "turned.yaml")
    assert load_variant(turned).kim_vectors == ()
    fig, _ = drawn(monkeypatch, cli, tmp_path, turned)
    texts = {t.get_text() for t in fig.findobj(lambda a: hasattr(a, "get_text"))}
    assert not texts & set(KIM_FRAME) and not any("frame vectors" in t for t in texts)
    assert text_problems(fig) == []


@pytest.mark.slow
def test_default_gamma_shows_a_working_machine_and_files_are_named_after_the_file(cli, tmp_path):
    """The default γ was 0, where the brake shaft stands still; now 45° as export's. The drawing is named
    after the variant file (two files with the same `name:` no longer overwrite each other's drawing), with
    the γ when one is given; a drawing replaced is said so."""
    copy = tmp_path / "my_copy.yaml"
    copy.write_text((ROOT / "variants/existing_kim.yaml").read_text())       # its name: is still 'existing'
    code, out, _ = cli("show", copy, "--out", tmp_path / "o")
    assert code == 0 and "at commanded γ = 45°" in out and "ideal ω2/ω1 = 1" in out
    assert (tmp_path / "o" / "my_copy_layout.png").exists() and "replaced" not in out
    assert cli("show", ROOT / "variants/existing_kim.yaml", "--out", tmp_path / "o", "--gamma", 30)[0] == 0
    assert sorted(p.name for p in (tmp_path / "o").iterdir()) == ["existing_kim_layout_gamma30.png", "my_copy_layout.png"]
    code, out, _ = cli("show", copy, "--out", tmp_path / "o")
    assert code == 0 and "(replaced the earlier drawing of this file at this γ)" in out


def arrows_and_shafts(ax) -> np.ndarray:
    """Points [pixels] along every arrow of an orthographic view (u(γ), the frame vectors, the front rollers'
    axles: annotations without text) and every front shaft (the thick shaft-coloured lines)."""
    from matplotlib.colors import to_rgba

    from cvtdesign.io.plots import points_along

    behind = to_rgba("lightsteelblue")
    lines = [np.array([t.xyann, t.xy], float) for t in ax.texts if not t.get_text() and t.arrow_patch is not None
             and not np.allclose(t.arrow_patch.get_edgecolor(), behind)]
    lines += [l.get_xydata() for l in ax.get_lines() if l.get_linewidth() == 2.5]
    return ax.transData.transform(points_along(*lines, per_segment=40))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["existing", "box", "unequal"])
def test_labels_keep_off_the_arrows_and_shafts(name, monkeypatch, cli, tmp_path):
    """In the side view d1 and d2 were written on the u(γ) arrow and u(γ) on the brake shaft; in the front
    view the box's A and B_ read as one block. Now no label covers an arrow or a front shaft, in any view."""
    fig, _ = drawn(monkeypatch, cli, tmp_path, ROOT / f"variants/{name}.yaml")
    renderer = fig.canvas.get_renderer()
    for title, *_ in layout_drawing.VIEWS:
        _, ax = view_labels(fig, title)
        pts = arrows_and_shafts(ax)
        for t in ax.texts:
            if t.get_text():
                box = t.get_window_extent(renderer)
                on = (pts[:, 0] > box.x0) & (pts[:, 0] < box.x1) & (pts[:, 1] > box.y0) & (pts[:, 1] < box.y1)
                assert not on.any(), f"{title}: {t.get_text()!r} covers an arrow or a shaft"
