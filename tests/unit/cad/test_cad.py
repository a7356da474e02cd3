"""`cvtdesign export`: the STEP assembly re-read and checked, the drawings, bad geometry refused, cadquery
kept off the model's import path."""
import dataclasses
import os
import re
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from importlib.metadata import version

from conftest import ROOT

from cvtdesign.cad import checks, picture, plan, shapes, step
from cvtdesign.cad.export import export_variant
from cvtdesign.cad.kernel import kernel
from cvtdesign.cli import main
from cvtdesign.cli.export import export_layout
from cvtdesign.core.geometry import pose
from cvtdesign.core.model import compile_model
from cvtdesign.io.variant import load_variant

BOX, EXISTING = ROOT / "variants/box_kim.yaml", ROOT / "variants/existing_kim.yaml"

# written out by hand from the variant files: sphere, rollers (role + name), axles, forks, couplings
BOX_PARTS = (["sphere", "drive_A", "follower_A_", "drive_B", "follower_B_", "steering_N1", "steering_N2",
              "steering_S1", "steering_S2"]
             + [f"axle_{n}" for n in ("A", "A_", "B", "B_", "N1", "N2", "S1", "S2")]
             + ["fork_1", "fork_2", "coupling_A_", "coupling_B_"])
EXISTING_PARTS = ["sphere", "drive_D1", "drive_D2", "steering_S1", "steering_S2", "axle_D1", "axle_D2", "axle_S1",
                  "axle_S2", "fork_1", "fork_2"]


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    out = tmp_path_factory.mktemp("cad")
    return out, {name: export_layout(path, out, check=True) for name, path in (("box_kim", BOX), ("existing_kim", EXISTING))}


@pytest.mark.slow
def test_step_svg_png_written_and_nothing_else(exported):
    out, res = exported
    assert sorted(p.name for p in out.iterdir()) == sorted(f"{n}.{e}" for n in res for e in ("png", "step", "svg"))
    for name, r in res.items():
        assert Path(r["step"]).read_text()[:13] == "ISO-10303-21;"
        svg = Path(r["svg"]).read_text()
        visible = svg.split("<!-- solid lines -->")[1]
        assert svg.startswith("<?xml") and visible.count("<path") >= len(r["parts"])   # an outline per part at least
        assert Path(r["png"]).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        umask = os.umask(0)
        os.umask(umask)
        for key in ("step", "svg", "png"):                     # readable like any new file, not mkstemp's 0600
            assert stat.S_IMODE(Path(r[key]).stat().st_mode) == 0o666 & ~umask


@pytest.mark.parametrize("name, parts", [("box_kim", BOX_PARTS), ("existing_kim", EXISTING_PARTS)])
def test_reimported_names_count_colours(exported, name, parts):
    _, res = exported
    assert res[name]["parts"] == parts
    back = step.read_step(Path(res[name]["step"]))
    assert list(back) == parts
    for part, (shape, colour) in back.items():
        assert len(shape.Solids()) == 1 and shape.Solids()[0].isValid(), part
        assert colour is not None
    assert np.allclose(back["drive_A" if name == "box_kim" else "drive_D1"][1], plan.COLOURS["drive"], atol=1e-3)
    assert np.allclose(back["steering_S1"][1], plan.COLOURS["steering"], atol=1e-3)


def test_box_parts_named_by_role(exported):
    """Every roller in box_kim.yaml's STEP file is its role and its name in the variant; no bare YAML id."""
    _, res = exported
    names = list(step.read_step(Path(res["box_kim"]["step"])))
    layout = load_variant(BOX)
    assert {"drive_A", "drive_B", "follower_A_", "follower_B_", "steering_N1", "fork_1", "sphere"} <= set(names)
    assert not {r.name for r in layout.rollers} & set(names)
    assert [n for n in names if n.split("_")[0] in ("drive", "follower", "steering")] == \
        [f"{r.role}_{r.name}" for r in layout.rollers]
    assert all(plan.named_by_role(n, layout) for n in names)
    assert not any(plan.named_by_role(n, layout) for n in ("A", "N1", "steering_A", "drive_N1", "coupling_A",
                                                           "fork_0", "fork_3", "axle_X"))


@pytest.mark.parametrize("name, gamma, phi", [("box_kim", 45.0, 45.0), ("existing_kim", 45.0, None)])
def test_step_header_read_back(exported, name, gamma, phi):
    """FILE_DESCRIPTION and FILE_NAME carry the variant, its file, γ, φ and cvtdesign's version (box: φ = γ,
    its forks turn about the pole axis)."""
    _, res = exported
    path = Path(res[name]["step"])
    text = path.read_text()
    head = text[:text.index("ENDSEC;")]
    assert f"FILE_NAME('{name}.step'," in head and f"'variant: {name}'" in head
    h = step.read_header(path)
    made_by = f"cvtdesign {version('cvtdesign')}"
    assert h["name"] == f"{name}.step" and h["originating_system"] == made_by
    said = dict(line.split(": ", 1) for line in h["description"])
    assert said["variant"] == name and said["variant file"] == str(BOX if name == "box_kim" else EXISTING)
    assert said["written by"] == made_by
    assert float(said["commanded gamma [deg]"]) == gamma
    assert abs(float(said["steering angle phi [deg]"]) - res[name]["phi_deg"]) < 1e-9
    if phi is not None:
        assert abs(float(said["steering angle phi [deg]"]) - phi) < 1e-6


@pytest.mark.parametrize("name", ["box_kim", "existing_kim"])
def test_all_checks_pass(exported, name):
    _, res = exported
    rows = {r["check"]: r for r in res[name]["checks"]}
    assert set(rows) == {"names and count", "part names by role", "one valid solid per part", "colours", "header",
                         "rollers touch the sphere at R·n", "no interference", "attached parts touch", "bounding box"}
    assert all(r["ok"] for r in rows.values()), [r for r in rows.values() if not r["ok"]]


def _bore_axis(shape):
    """(point, direction) of the wheel's hub bore (its one cylindrical face) [mm]."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface

    (bore,) = [f for f in shape.Faces() if f.geomType() == "CYLINDER"]
    ax = BRepAdaptor_Surface(bore.wrapped).Cylinder().Axis()
    return np.array(ax.Location().Coord()), np.array(ax.Direction().Coord())


@pytest.mark.slow
def test_step_header_round_trip_wrapped_and_quoted(tmp_path):
    """A variant file whose path has a quote and is long enough that the writer breaks it across lines comes
    back from the header exactly as written."""
    folder = tmp_path / "the rig's variants, in a folder with a long name so that the header wraps"
    folder.mkdir()
    path = folder / "existing_kim.yaml"
    path.write_text(EXISTING.read_text())
    header = step.step_header(plan.plan(load_variant(path), 30.0), "one_ball.step")
    cq = kernel().cq
    assy = cq.Assembly(name="one_ball")
    assy.add(cq.Solid.makeSphere(10.0), name="sphere")
    step.write_step(assy, tmp_path / "one_ball.step", header)
    text = (tmp_path / "one_ball.step").read_text()
    assert f"variant file: {path}" not in text and "rig''s" in text     # broken across lines, quote doubled
    back = step.read_header(tmp_path / "one_ball.step")
    assert {key: back[key] for key in header} == header
    assert back["description"][1] == f"variant file: {path}"


@pytest.mark.slow
def test_cli_end_to_end_wheels_where_the_model_puts_them(tmp_path, capsys):
    """Kim's CVT at γ = 30°: the linkage turns the forks by φ ≈ −20.75°; every wheel in the STEP file has its
    axis along the model's axle at that φ, through (R + r)·n, and all checks pass."""
    assert main(["export", str(EXISTING), "--out", str(tmp_path), "--gamma", "30", "--check"]) == 0
    out = capsys.readouterr().out
    assert "11 parts at γ = 30°" in out and "FAILED" not in out
    layout = load_variant(EXISTING)
    phi = float(compile_model(layout).evaluate(np.radians([30.0]), [0.0])["phi"][0])
    assert abs(np.degrees(phi) + 20.75) < 0.01
    back = step.read_step(tmp_path / "existing_kim.step")
    said = dict(line.split(": ", 1) for line in step.read_header(tmp_path / "existing_kim.step")["description"])
    assert said["commanded gamma [deg]"] == "30" and abs(float(said["steering angle phi [deg]"]) - np.degrees(phi)) < 1e-6
    R = 1000 * layout.sphere_radius
    for r in layout.rollers:
        n, a = pose(r, phi)
        point, direction = _bore_axis(back[f"{r.role}_{r.name}"][0])
        centre = (R + 1000 * r.radius) * n
        assert abs(abs(direction @ a) - 1) < 1e-9, r.name
        assert np.linalg.norm(np.cross(point - centre, direction)) < 1e-6, r.name


def test_steering_angle_is_the_models():
    for path, gammas in ((EXISTING, [-30, 0, 30, 45, 70]), (BOX, [-60, 45])):
        layout = load_variant(path)
        model_phi = compile_model(layout).evaluate(np.radians(gammas), np.zeros(len(gammas)))["phi"]
        ours = [plan.steering_angle(layout, g) for g in np.radians(gammas)]
        assert np.max(np.abs(np.array(ours) - model_phi)) < 1e-9


def _moved_roller(p, name, shift):
    """The plan with roller `name` moved by `shift` [mm] along its contact normal (a geometry fault)."""
    parts = []
    for part in p.parts:
        if part.name == name:
            w = part.prims[0]
            part = dataclasses.replace(part, prims=[dataclasses.replace(w, centre=w.centre + shift * w.normal)])
        parts.append(part)
    return dataclasses.replace(p, parts=parts)


def test_checks_catch_a_roller_pushed_into_the_sphere(tmp_path):
    """The checks are not vacuous: D1 pushed 1 mm into the sphere overlaps it, hits its own axle (the bore's
    clearance is 0.5 mm) and moves the bounding box; a missing part is reported by name, a bare roller name
    as not named by role, a header of another file and γ as wrong."""
    p = plan.plan(load_variant(EXISTING))
    faulty = _moved_roller(p, "drive_D1", -1.0)
    solids, _ = step.build(faulty)
    step.write_step(step.assembly(faulty, solids), tmp_path / "faulty.step", step.step_header(p, "faulty.step"))
    rows = {r["check"]: r for r in checks.check_step(tmp_path / "faulty.step", p)}
    assert not rows["rollers touch the sphere at R·n"]["ok"] and "drive_D1" in rows["rollers touch the sphere at R·n"]["detail"]
    assert not rows["no interference"]["ok"] and "(drive_D1/axle_D1)" in rows["no interference"]["detail"]
    assert not rows["bounding box"]["ok"]
    assert all(rows[c]["ok"] for c in ("names and count", "part names by role", "one valid solid per part", "header"))

    short = dataclasses.replace(p, parts=[dataclasses.replace(q, name="D1") if q.name == "drive_D1" else q
                                          for q in p.parts[:-1]])
    solids["D1"] = solids["drive_D1"]
    other = step.step_header(plan.plan(load_variant(EXISTING), 30.0), "other.step")
    step.write_step(step.assembly(short, solids), tmp_path / "short.step", other)
    rows = {r["check"]: r for r in checks.check_step(tmp_path / "short.step", p)}
    assert not rows["names and count"]["ok"] and "missing ['drive_D1', 'fork_2']" in rows["names and count"]["detail"]
    assert not rows["part names by role"]["ok"] and rows["part names by role"]["detail"] == "not named by role: ['D1']"
    assert not rows["header"]["ok"]
    assert "commanded gamma [deg] '30', expected 45" in rows["header"]["detail"]
    assert "file name 'other.step', expected 'short.step'" in rows["header"]["detail"]


@pytest.mark.slow
def test_hull_gap_is_a_lower_bound_of_the_distance():
    """The fast screen may only pass pairs that are really apart: its gap never exceeds OpenCascade's distance."""
    cq = kernel().cq
    p = plan.plan(load_variant(BOX))
    prims = {part.name: part.prims for part in p.parts}
    for a, b in [("drive_A", "axle_B"), ("steering_N1", "fork_2"), ("coupling_A_", "steering_N2"),
                 ("follower_B_", "coupling_B_"), ("steering_N1", "steering_N2")]:
        for pa in prims[a]:
            for pb in prims[b]:
                exact = pa.solid(cq).distance(pb.solid(cq))
                assert step.hull_gap(pa, pb) <= exact + 1e-6, (a, b)


def _variant(tmp_path, base, *pairs, extra=""):
    text = base.read_text()
    for old, new in pairs:
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / "bad.yaml"
    path.write_text(text + extra)
    return path


ONE_FORK = ("    - {rollers: [N1, N2], axis: z, sign: 1}\n    - {rollers: [S1, S2], axis: z, sign: 1}\n",
            "    - {rollers: [N1, N2, S1, S2], axis: z, sign: 1}\n")
BAD = {
    "roller inside another": (EXISTING, [("S2: {role: steering, contact: c2, axle: c1,", "S2: {role: steering, contact: c1, axle: c2,"),
                                         ("{rollers: [S2], axis: c2, sign: -1}", "{rollers: [S2], axis: c1, sign: 1}")], "",
                              r"rollers\.S1, rollers\.S2: the two rollers overlap"),
    "plate through the assembly": (BOX, [], "frame: {side: -z, distance: 120 mm}\n",
                                   r"frame\.distance: the plate at 120 mm would cut part \w+ .*expected at least 1\d\d\.\d mm"),
    "crown narrower than the wheel": (EXISTING, [("radius: 40 mm, crown_radius: 15 mm", "radius: 40 mm, crown_radius: 10 mm")], "",
                                      r"rollers\.D1\.crown_radius: a crown of 10 mm cannot span the 24 mm wide wheel"),
}


@pytest.mark.parametrize("case", BAD)
def test_impossible_geometry_refused_before_writing(case, tmp_path, capsys):
    base, pairs, extra, pattern = BAD[case]
    path = _variant(tmp_path, base, *pairs, extra=extra)
    out = tmp_path / "cad"
    assert main(["export", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"cvtdesign: error: {path}: ")
    assert re.search(pattern, err), err
    assert not out.exists()


def test_mounting_plate_from_the_variant(tmp_path):
    path = tmp_path / "framed.yaml"
    path.write_text(BOX.read_text() + "frame: {side: -z, distance: 200 mm, thickness: 12 mm}\n")
    p = plan.plan(load_variant(path))
    plate = p.parts[-1]
    assert plate.name == "frame" and p.names()[:-1] == BOX_PARTS
    assert abs(plate.support(np.array([0.0, 0.0, 1.0])) + 200.0) < 1e-9     # near face 200 mm below the centre
    assert abs(plate.support(np.array([0.0, 0.0, -1.0])) - 212.0) < 1e-9    # 12 mm thick
    rest = np.array([q.bbox() for q in p.parts[:-1]])                       # it covers the rest's outline
    assert np.allclose(plate.bbox()[0][:2], rest[:, 0, :2].min(axis=0) - plan.FRAME_MARGIN)
    assert np.allclose(plate.bbox()[1][:2], rest[:, 1, :2].max(axis=0) + plan.FRAME_MARGIN)


@pytest.mark.parametrize("step", ["svg_text", "write_step"])
def test_failed_drawing_leaves_no_file(tmp_path, monkeypatch, step):
    """A failure in the forked SVG process or in this one, while the plotting process writes the PNG, leaves
    no file, not even a temporary one."""
    def broken(*args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr(f"cvtdesign.cad.export.{step}", broken)
    with pytest.raises(RuntimeError, match="disk full"):
        export_layout(EXISTING, tmp_path / "cad")
    assert list((tmp_path / "cad").iterdir()) == []


def test_rasterise_is_a_z_buffer():
    """The scanline rasteriser marks the same pixels, with the nearest triangle's part and shade, as testing
    every pixel centre against every triangle."""
    rng = np.random.default_rng(4)
    centre = rng.uniform(0, 50, (60, 1, 3))
    tri = centre + rng.normal(0, 6, (60, 3, 3))
    ids, shade = np.arange(60) % 4, rng.uniform(0.4, 1, 60)
    colours = rng.uniform(0, 1, (4, 3))
    pixels = 64
    image = picture.raster(tri, ids, shade, colours, pixels)[0]
    # the same transform to pixels, then every centre tested against every triangle
    t = tri.copy()
    lo, hi = t[..., :2].reshape(-1, 2).min(axis=0), t[..., :2].reshape(-1, 2).max(axis=0)
    t[..., :2] = (t[..., :2] - (lo + hi) / 2) * (0.94 * pixels / max(hi - lo)) + pixels / 2
    t[..., 1] = pixels - t[..., 1]
    q = np.stack(np.meshgrid(np.arange(pixels) + 0.5, np.arange(pixels) + 0.5), axis=-1).reshape(-1, 1, 2)
    m = np.stack([t[:, 0, :2] - t[:, 2, :2], t[:, 1, :2] - t[:, 2, :2]], axis=-1)          # (T, 2, 2)
    w = np.einsum("tij,ptj->pti", np.linalg.inv(m), q - t[:, 2, :2])                     # (P, T, 2)
    inside = (w.min(axis=2) >= 1e-9) & (w.sum(axis=2) <= 1 - 1e-9)
    z = np.where(inside, t[:, 2, 2] + w[..., 0] * (t[:, 0, 2] - t[:, 2, 2]) + w[..., 1] * (t[:, 1, 2] - t[:, 2, 2]),
                 -np.inf)
    nearest, hit = np.argmax(z, axis=1), inside.any(axis=1)
    part = np.where(hit, ids[nearest], -1).reshape(pixels, pixels)
    expected = np.where(hit[:, None], colours[ids[nearest]] * shade[nearest][:, None], 1.0).reshape(pixels, pixels, 3)
    edge = np.zeros_like(part, dtype=bool)
    edge[1:, :] |= part[1:, :] != part[:-1, :]
    edge[:, 1:] |= part[:, 1:] != part[:, :-1]
    expected[edge] *= 0.25
    assert np.mean(np.any(np.abs(image - expected) > 1e-9, axis=2)) < 0.002   # a centre on an edge may differ


def test_triangles_are_cadquerys_tessellation():
    """The mesh read from OpenCascade is cadquery's `tessellate`: the wheel's faces are placed by a location,
    13 of the fork's are reversed."""
    p = plan.plan(load_variant(BOX))
    solids, _ = step.build(p)
    for name in ("drive_A", "fork_1"):
        verts, idx = picture.triangles(solids[name])
        cq_verts, cq_idx = solids[name].tessellate(0.5, 0.4)
        assert np.array_equal(idx, np.array(cq_idx))
        assert np.allclose(verts, [v.toTuple() for v in cq_verts], rtol=0, atol=1e-12)


@pytest.mark.slow
def test_model_path_does_not_import_cadquery():
    code = ("import sys, cvtdesign.cli, cvtdesign.core.model, cvtdesign.design.solve, cvtdesign.design.study, "
            "cvtdesign.cad.export, cvtdesign.cad.checks, cvtdesign.cad.picture, cvtdesign.cad.kernel; "
            "print(sorted(m for m in ('cadquery', 'OCP') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


# ------------------------------------------------------------------ accepted means exportable (issue 25)

import layout_transforms as lt  # noqa: E402
from hypothesis import HealthCheck, Phase, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from cvtdesign.errors import InputError  # noqa: E402


def two_on_one_fork() -> dict:
    """Kim's CVT with a third steering roller S3 at −c2 on S2's fork (axis c2, sign −1), S2's preload doubled
    so that the preloads balance: `show` and `compare` take it; its export ended in a traceback ('part fork_2:
    its primitives fused into 2 solids')."""
    d = lt.read("existing_kim")
    d["rollers"]["S2"]["preload"] = "200 N"
    d["rollers"]["S3"] = dict(d["rollers"]["S2"], contact="-c2", preload="100 N")
    d["steering"]["forks"][1]["rollers"] = ["S2", "S3"]
    return d


@pytest.mark.slow
@pytest.mark.parametrize("case", ["two steering rollers on one fork", "one fork for both pole pairs",
                                  "one fork for both pole pairs near the poles"])
def test_a_fork_with_rollers_on_both_sides_of_the_sphere_is_exported(case, tmp_path, capsys):
    """A fork whose rollers lie on both sides of the sphere: the far rollers' yokes join it by rods round the
    sphere. Two rollers on one fork ended in a traceback ('part fork_2: its primitives fused into 2 solids');
    the box CVT's pole pairs on one fork were refused (its rods ran up through the sphere or a roller)
    although compare takes both. Now each is one valid solid touching its axles, and every check passes."""
    if case == "two steering rollers on one fork":
        path, parts, joints = lt.dump(two_on_one_fork(), tmp_path / "two_on_one_fork.yaml"), 13, 3
    else:
        near = [("d: 60 mm", "d: 50 mm")] if case.endswith("poles") else []
        path, parts, joints = _variant(tmp_path, BOX, ONE_FORK, *near), 20, 8
    assert main(["export", str(path), "--out", str(tmp_path / "cad"), "--check"]) == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    assert "FAILED" not in out and f"{parts} parts" in out and f"{joints} fork–axle" in out


def test_a_part_running_into_another_is_refused_before_writing(tmp_path):
    """The screen: a fork rod planned from the stem through a roller of the other fork is one InputError line
    naming the fork's field, before anything is written."""
    p = plan.plan(load_variant(EXISTING))
    fork = next(part for part in p.parts if part.name == "fork_1")
    wheel = next(part for part in p.parts if part.name == "steering_S2").prims[0]
    fork.prims.append(shapes.Rod(fork.prims[-1].p1, wheel.centre, plan.FORK_ROD))     # from its stem's top
    _, pieces = step.build(p)
    with pytest.raises(InputError, match=r"steering\.forks\[0\]: part fork_1 runs into (sphere|steering_S2)"):
        step.screen(p, pieces)


@st.composite
def exportable_layouts(draw):
    """A shipped layout (or the one with two rollers on a fork), its drive rollers at radii 25–50 mm, rotated,
    possibly mirrored, with random axle flips; and a commanded γ inside its envelope."""
    name = draw(st.sampled_from(["existing_kim", "box_kim", "unequal_kim", "two on one fork"]), label="variant")
    d = two_on_one_fork() if name == "two on one fork" else lt.read(name)
    for rn in [n for n, s in d["rollers"].items() if s["role"] == "drive"]:
        d = lt.set_radius(d, rn, draw(st.floats(0.025, 0.050), label=f"{rn} radius [m]"))
    for rn in draw(st.lists(st.sampled_from(sorted(d["rollers"])), unique=True, max_size=2), label="flip axles"):
        d = lt.flip_axle(d, rn)
    unit_interval = st.floats(-1.0, 1.0)
    q = draw(st.tuples(*[unit_interval] * 4).filter(lambda v: np.linalg.norm(v) > 0.2), label="rotation q")
    d = lt.rotate(d, lt.quaternion_matrix(q))
    if draw(st.booleans(), label="mirror"):
        v = draw(st.tuples(*[unit_interval] * 3).filter(lambda v: np.linalg.norm(v) > 0.2), label="mirror normal")
        d = lt.mirror(d, lt.householder(v))
    return d, draw(st.sampled_from([-60.0, -20.0, 0.0, 30.0, 70.0]), label="γ [deg]")


@pytest.mark.slow
@settings(max_examples=4, deadline=None, derandomize=True, database=None, phases=(Phase.explicit, Phase.generate),
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture], print_blob=False)
@given(case=exportable_layouts())
def test_a_layout_the_tool_accepts_is_exported(case, tmp_path_factory):
    """Whatever valid layout `load_variant` accepts exports: the STEP file and drawings are written and every
    check of the re-read file passes, or the export refuses it in one InputError line; never another error."""
    data, gamma = case
    folder = tmp_path_factory.mktemp("random")
    path = lt.dump(data, folder / "random.yaml")
    layout = load_variant(path)
    try:
        res = export_variant(layout, folder / "cad", gamma_deg=gamma, check=True)
    except InputError as e:
        assert "\n" not in str(e) and str(path) in str(e)
        return
    failed = [f"{c['check']}: {c['detail']}" for c in res["checks"] if not c["ok"]]
    assert not failed, failed


# ------------------------------------------------------------------ drawings a review can use (issue 28)

from figure_checks import captured, text_problems  # noqa: E402

from cvtdesign.io import plots  # noqa: E402


def test_svg_centred_named_scaled_without_empty_groups(exported):
    """The SVG was off-centre, had an empty hidden-line group, no part names, scale or legend, and the
    couplings' loops round the box. Now its lines sit in the middle of the drawing's square, every group
    holds something, each roller, fork and the sphere is named as in the STEP file, a scale bar and a legend
    say what is what, and the couplings are left out, the legend saying which rollers they join."""
    _, res = exported
    for name, r in res.items():
        svg = Path(r["svg"]).read_text()
        assert svg.count("<g") == 1 and "stroke-dasharray" not in svg          # the hidden-line group is gone
        transform = re.search(r'translate\(([-\d.]+),([-\d.]+)\) scale\(([-\d.]+),', svg)
        tx, ty, k = map(float, transform.groups())
        lines = svg.split("<!-- solid lines -->")[1].split("</g>")[0]
        xy = np.array(re.findall(r"[ML]\s*(-?[\d.]+(?:e-?\d+)?),(-?[\d.]+(?:e-?\d+)?)", lines), float)
        left, right = tx + k * xy[:, 0].min(), tx + k * xy[:, 0].max()
        top, bottom = ty - k * xy[:, 1].max(), ty - k * xy[:, 1].min()         # the drawing's y is up
        assert abs((left + right) / 2 - picture.SVG_SIZE / 2) < 1 and abs((top + bottom) / 2 - (40 + picture.SVG_SIZE / 2)) < 1
        assert min(left, top - 40) > 0.05 * picture.SVG_SIZE
        texts = re.findall(r">([^<>]+)</text>", svg)
        named = [p for p in r["parts"] if p.split("_")[0] in ("sphere", "drive", "follower", "steering", "fork")]
        assert set(named) <= set(texts) and any(t.endswith(" mm") for t in texts)
        assert ("A_ turns with A (shaft 1); B_ turns with B (shaft 2)" in svg) == (name == "box_kim")
    p = plan.plan(load_variant(BOX))
    assert "coupling_A_" in p.names()                      # still in the STEP file


def test_png_names_parts_with_a_scale_and_a_legend(monkeypatch, tmp_path):
    """The PNG had no part labels, no scale and no legend. Each named part's label sits on a pixel of that
    part; the scale bar's length is round and a fifth of the picture or less; no text is cut or overlaps."""
    figures = captured(monkeypatch, plots)
    p = plan.plan(load_variant(BOX))
    solids, _ = step.build(p)
    image, part, extent = picture.raster(*picture.view_mesh(p, solids), [q.colour for q in p.parts], 400)
    notes = picture.annotations(p, part, extent)
    names = [n for n, _ in notes["labels"]]
    assert names == [q.name for q in p.parts if q.kind in ("sphere", "roller", "fork")]
    x0, x1, y0, y1 = extent
    for n, (x, y) in notes["labels"]:
        row, col = int((y1 - y) / (y1 - y0) * 400), int((x - x0) / (x1 - x0) * 400)
        assert p.parts[part[row, col]].name == n
    assert not any(q.kind == "coupling" for q in p.parts if q.name in (p.parts[i].name for i in np.unique(part[part >= 0])))
    plots.cad_picture(np.round(255 * image).astype(np.uint8), extent, picture.picture_caption(p), tmp_path / "b.png", notes)
    fig = figures[-1]
    assert text_problems(fig) == []
    texts = [t.get_text() for t in fig.axes[0].texts]
    assert set(names) <= set(texts) and f"{plots.scale_bar(x1 - x0):g} mm" in texts
    assert plots.scale_bar(x1 - x0) in (50.0, 100.0)
    assert [t.get_text() for t in fig.legends[0].get_texts()][:2] == ["sphere", "drive roller: drive_<roller>"]
