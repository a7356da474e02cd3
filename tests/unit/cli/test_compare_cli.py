"""`cvtdesign compare`: the table, the JSON figures and the plot, end to end; the files before the terminal."""
import io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import ROOT, shipped_model

from cvtdesign.cli import main
from cvtdesign.core.metrics import envelope, ideal_model, metrics
from cvtdesign.core.contact.laws import EPS_RIGID
from cvtdesign.io.variant import load_variant

KEYS = {"name", "file", "max_abs_alpha_deg", "rms_alpha_deg", "max_abs_alpha_steering_deg",
        "max_abs_alpha_drive_deg", "ratio_error_pct_at_max_load", "min_efficiency",
        "max_traction_utilisation", "max_hertz_pressure_MPa"}


@pytest.fixture(scope="module")
def box_vs_existing(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("compare")
    code = main(["compare", str(ROOT / "variants/box_kim.yaml"), "--out", str(tmp / "plots"), "--json", str(tmp / "f.json"),
                 "--samples", "0"])      # the table and the plot; the sampled intervals: test_uncertainty.py
    return code, tmp


def test_single_file_compares_with_ideal_and_existing(box_vs_existing, monkeypatch):
    code, tmp = box_vs_existing
    assert code == 0
    rows = json.loads((tmp / "f.json").read_text())["variants"]
    assert [r["name"] for r in rows] == ["ideal (box_kim)", "existing_kim", "box_kim"]
    for r in rows:
        assert KEYS <= set(r)
    ideal, existing, box = rows
    # the ideal CVT slips only by the model's rigid-direction floor: α ≲ EPS_RIGID · F with F < 50 N
    assert ideal["max_abs_alpha_deg"] < np.degrees(EPS_RIGID * 50) and ideal["min_efficiency"] > 1 - 1e-6
    # Kim sec. 5.1: the box CVT slips less in both parts
    assert box["max_abs_alpha_drive_deg"] < 0.6 * existing["max_abs_alpha_drive_deg"]
    assert box["max_abs_alpha_steering_deg"] < 0.5 * existing["max_abs_alpha_steering_deg"]
    assert box["min_efficiency"] > existing["min_efficiency"]


def test_plot_written(box_vs_existing):
    _, tmp = box_vs_existing
    png = tmp / "plots" / "box_kim.png"                # named after the input file
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000
    assert [p.name for p in (tmp / "plots").iterdir()] == ["box_kim.png"]   # no temporary files left


@pytest.mark.slow
def test_three_variants_side_by_side(tmp_path, capsys):
    files = [str(ROOT / f"variants/{n}.yaml") for n in ("existing_kim", "box_kim", "unequal_kim")]
    assert main(["compare", *files, "--out", str(tmp_path), "--json", str(tmp_path / "f.json")]) == 0
    rows = json.loads((tmp_path / "f.json").read_text())["variants"]
    assert [r["name"] for r in rows] == ["existing_kim", "box_kim", "unequal_kim"]
    # each figure is its own variant's: max |α| over the envelope, re-evaluated here from the compiled model
    for r in rows:
        m = shipped_model(r["name"])
        G, T = np.meshgrid(m.layout.gamma_grid, m.layout.load_grid, indexing="ij")
        assert r["max_abs_alpha_deg"] == pytest.approx(np.degrees(np.nanmax(np.abs(m.evaluate(G, T)["alpha"]))),
                                                       rel=1e-9), r["name"]
    table = capsys.readouterr().out
    assert "max |α| [°]" in table and "unequal_kim" in table


@pytest.mark.slow
def test_single_file_outside_the_repository_still_compares_with_existing(tmp_path, monkeypatch, make_variant):
    """Run from another folder with a copy of box_kim.yaml there: Kim's existing CVT comes from the package, not
    from a `variants/` folder beside the working directory, so its column is never silently dropped."""
    box = make_variant("box_kim")
    monkeypatch.chdir(tmp_path)
    assert main(["compare", str(box), "--out", "plots", "--json", "f.json"]) == 0
    rows = json.loads((tmp_path / "f.json").read_text())["variants"]
    assert [r["name"] for r in rows] == ["ideal (box_kim)", "existing_kim", "box_kim"]
    assert rows[1]["max_abs_alpha_deg"] == pytest.approx(10.761, abs=5e-4)


@pytest.mark.slow
def test_roller_defaults_supply_any_roller_field(make_variant, tmp_path):
    """A roller field given once in roller_defaults means the same as on every roller that omits it: the
    drive rollers' radius and material moved there give figures identical to the file that repeats them."""
    def hoist(data):
        rollers = data["rollers"]
        data["roller_defaults"] |= {"radius": rollers["D1"]["radius"], "material": rollers["D1"]["material"]}
        for r in ("D1", "D2"):
            del rollers[r]["radius"], rollers[r]["material"]
    hoisted = make_variant("existing_kim", hoist, file="hoisted")
    assert main(["compare", str(ROOT / "variants/existing_kim.yaml"), str(hoisted), "--out", str(tmp_path / "p"),
                 "--json", str(tmp_path / "f.json")]) == 0
    a, b = json.loads((tmp_path / "f.json").read_text())["variants"]
    assert {k: v for k, v in a.items() if k not in ("name", "file")} == \
        {k: v for k, v in b.items() if k not in ("name", "file")}


def test_the_ideal_cvt_is_ideal_under_kalkers_law():
    """Kalker's law creeps with no effect on, so the 'ideal' column of `compare box.yaml` slipped like
    the variant (max |α| 4.185°). The ideal CVT is the layout with rigid rolling contacts, whatever its law."""
    for name in ("box", "box_kim"):
        m = ideal_model(load_variant(ROOT / f"variants/{name}.yaml"))
        row = metrics(m, envelope(m))
        assert row["max_abs_alpha_deg"] < np.degrees(EPS_RIGID * 50) and row["min_efficiency"] > 1 - 1e-6, name


def heavy(data, loads=("-20 N*m", "20 N*m", "2 N*m"), allowable="2.5 MPa", name="heavy"):
    """Kim's CVT loaded up to 20 N·m (within what its preloads can carry at all, beyond what most points can),
    its steering rollers' urethane allowed 2.5 MPa (they reach 3.05)."""
    data["name"] = name
    data["envelope"]["load"] = dict(zip(("start", "stop", "step"), loads))
    data["materials"]["urethane_84A"]["allowable_pressure"] = allowable


@pytest.mark.slow
def test_a_table_never_looks_better_than_the_run(make_variant, tmp_path, capsys):
    """A variant with 38 of 357 points ok printed a clean column (its failures in a footnote only), and a
    Hertz pressure over the allowable had no mark. Now a first row says 'under half' in its column, a figure
    over no ok point is '—' (never 0.000), and the pressure is marked in the table, the JSON and the report."""
    files = [make_variant("existing_kim", heavy, file="heavy"),
             make_variant("existing_kim", lambda d: heavy(d, ("10 N*m", "30 N*m", "10 N*m"), name="hopeless"),
                          file="hopeless")]
    report = tmp_path / "r.html"
    assert main(["compare", *map(str, files), "--out", str(tmp_path / "p"), "--json", str(tmp_path / "f.json"),
                 "--report", str(report), "--as-written"]) == 0
    rows = {r["name"]: r for r in json.loads((tmp_path / "f.json").read_text())["variants"]}
    h, z = rows["heavy"], rows["hopeless"]
    assert 0 < 2 * h["ok"] < h["points"] and z["ok"] == 0
    assert h["max_hertz_pressure_over_allowable"] is True and h["hertz_allowable_pressure_MPa"] == pytest.approx(2.5)
    assert set(h["hertz_over_allowable_at"]) == {"S1", "S2"} and h["max_hertz_pressure_MPa"] > 2.5
    table = {line.split("│")[1].strip(): [c.strip() for c in line.split("│")[2:-1]]
             for line in capsys.readouterr().out.splitlines() if line.startswith("│")}
    assert table["operating points ok"] == [f"{h['ok']} of {h['points']} (under half)",
                                            f"0 of {z['points']} (under half)"]
    cell = table["max Hertz p [MPa]"][0]
    assert cell.startswith(f"{h['max_hertz_pressure_MPa']:.2f} [") and cell.endswith("] > 2.5 allowed")
    assert all(cells[1] == "—" for label, cells in table.items()        # Kim's law has no rolling steering
               if label not in ("operating points ok", "contact law", "calibration", "max steering torque [N·m]"))
    assert table["max steering torque [N·m]"][1] == "not modelled"   # torque to report: not modelled, never 0
    assert "&gt; 2.5 allowed" in report.read_text() and "(under half)" in report.read_text()


@pytest.mark.slow
def test_the_files_are_written_before_the_table_and_a_closed_pipe_is_quiet(tmp_path):
    """`compare … --json f | head` lost the JSON: it was written after the table, which the closed pipe
    stopped. Now the JSON, the report and the plot are there, and nothing is said about the pipe."""
    script = Path(sys.executable).parent / "cvtdesign"
    proc = subprocess.Popen([str(script), "compare", str(ROOT / "variants/box_kim.yaml"), "--out", str(tmp_path / "p"),
                             "--json", str(tmp_path / "f.json"), "--report", str(tmp_path / "r.html")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    proc.stdout.close()                  # the reader is gone before anything is printed
    err = proc.stderr.read()
    assert proc.wait(timeout=120) == 1 and err == "", err
    assert json.loads((tmp_path / "f.json").read_text())["variants"][-1]["name"] == "box_kim"
    assert (tmp_path / "r.html").stat().st_size > 0 and (tmp_path / "p" / "box_kim.png").exists()


class ClosedPipe(io.StringIO):
    """stdout whose reader has gone: every write raises BrokenPipeError (its fileno is a file's, for rich to
    send the rest to /dev/null)."""

    def __init__(self, fd: int):
        super().__init__()
        self.fd = fd

    def write(self, text):
        raise BrokenPipeError(32, "Broken pipe")

    def fileno(self):
        return self.fd


@pytest.mark.parametrize("argv, written", [
    (["show", "{existing}", "--out", "{tmp}/s"], ["s/existing_kim_layout.png"]),
    (["contact", "{existing}", "--json", "{tmp}/c.json", "--plots", "{tmp}/c"], ["c.json", "c"]),
    (["resteer", "--variant", "{existing}", "--load", "0.5 N*m", "--json", "{tmp}/r.json"], ["r.json"]),
    (["cache"], []),
], ids=["show", "contact", "resteer", "cache"])
def test_every_command_writes_its_files_before_the_terminal(argv, written, tmp_path, monkeypatch, capfd):
    """With stdout closed from the start, each command still writes its files, exits 1 and prints nothing
    else (no BrokenPipeError traceback)."""
    with open(tmp_path / "stdout", "w") as sink:
        monkeypatch.setattr(sys, "stdout", ClosedPipe(sink.fileno()))
        args = [a.format(existing=ROOT / "variants/existing_kim.yaml", tmp=tmp_path) for a in argv]
        try:
            code = main(args)
        except SystemExit as e:          # rich's own handling of a closed pipe
            code = e.code
    assert code == 1 and capfd.readouterr().err == ""
    for f in written:
        assert (tmp_path / f).exists(), f
