"""Engineering units in what the commands print, and the HTML report (--report) of compare, optimise and
diagnose, opened in a headless browser: its tables hold the printed values and its figures decode."""
import json
import math
import re
import shutil
import subprocess
from html.parser import HTMLParser
from importlib.metadata import version
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from conftest import ROOT

from cvtdesign.cli import main
from cvtdesign.cli.compare import COLUMNS
from cvtdesign.cli.compare_report import MEANINGS
from cvtdesign.cli.diagnosis_text import value_pm
from cvtdesign.cli.printing import kind_of
from cvtdesign.cli.study import best_optima, optima_table, pareto_blocks
from cvtdesign.core.effects import EFFECTS
from cvtdesign.diagnosis import rig
from cvtdesign.io.report import READABLE, Note, Table, html_report
from cvtdesign.io.units import degrees, engineering, number
from cvtdesign.io.variant import load_variant

BOX = ROOT / "variants" / "box_kim.yaml"
EXISTING = ROOT / "variants" / "existing_kim.yaml"
BROWSER = next((shutil.which(b) for b in ("chromium", "chromium-browser", "google-chrome") if shutil.which(b)), None)
# run once the page and its images have loaded: each <img> gets its decoded width and the width it is shown at; the body the page's width,
# its scroll width and the elements that reach past the page's edges (a table scrolling in its own box may),
# and a mark
ONLOAD = ('<script>window.addEventListener("load", () => { for (const i of document.images) { '
          'i.setAttribute("data-natural-width", i.naturalWidth); '
          'i.setAttribute("data-shown-width", i.getBoundingClientRect().width); } '
          'const w = document.documentElement.clientWidth, out = []; '
          'for (const e of document.body.querySelectorAll("*")) { if (e.parentElement.closest(".scroll")) continue; '
          'const r = e.getBoundingClientRect(); if (r.right > w + 0.5 || r.left < -0.5) out.push(e.tagName); } '
          'document.body.setAttribute("data-page-width", w); '
          'document.body.setAttribute("data-scroll-width", document.documentElement.scrollWidth); '
          'document.body.setAttribute("data-overflow", out.join(" ") || "none"); '
          'document.body.setAttribute("data-loaded", "yes"); });'
          '</script></body>')


@pytest.mark.parametrize("value, kind, text", [
    (0.0319401, "length", "31.94 mm"), (0.1435, "length", "143.5 mm"), (9.92e-05, "length", "0.0992 mm"),
    (math.radians(3.1), "angle", "3.1°"), (6e6, "pressure", "6 MPa"), (0.0038, "compliance", "0.0038 1/N"),
    (1.2, "power", "1.2 W"), (100.0, "force", "100 N"), (0.5, "torque", "0.5 N·m"), (0.8, "dimensionless", "0.8"),
    (1e5, "stiffness", "100 N/mm"), (float("nan"), "length", "—"), (None, "force", "—"), (-0.0, "length", "0 mm"),
])
def test_engineering_units(value, kind, text):
    assert engineering(value, kind) == text


def test_numbers_and_kinds():
    assert [number(v) for v in (12345.6, 1e-6, 2.5e7, 0.0)] == ["12350", "1e-6", "2.5e+7", "0"]
    assert degrees(4.1663) == "4.166°"
    assert [kind_of(r) for r in ("30 mm", "10 deg", "100 N", "0.0038 1/N", "1 N*m", "25 MPa")] == \
        ["length", "angle", "force", "compliance", "torque", "pressure"]
    # plain numbers and expressions say nothing: the next value decides
    assert kind_of("= 2*R", 0.03, "30 mm") == "length" and kind_of(0.5, "= a") == "dimensionless"


def test_report_escapes_text():
    text = html_report("t <x>", "cvtdesign compare 'a&b.yaml'", "1.0",
                       [Table("<b>", ["a", "b"], [["<script>", "1 & 2"]], [""]), Note("<i>", "bad")])
    assert "<script>" not in text and "<b>" not in text and "<i>" not in text
    assert "&lt;script&gt;" in text and "1 &amp; 2" in text and "&lt;i&gt;" in text and "&#x27;a&amp;b.yaml&#x27;" in text


class Tables(HTMLParser):
    """The tables of a document by caption ({caption: [[cell text, ...] per row, header row first]}), the
    <img> elements' attributes, the text of the elements with an id, the body's attributes, the glossary's
    terms, and the order of the sections, figures, tables and headings (by id, else by tag)."""

    def __init__(self):
        super().__init__()
        self.tables, self.images, self.ids, self.body, self.terms, self.order = {}, [], {}, {}, [], []
        self._term = None
        self._rows, self._cell, self._caption, self._id = None, None, None, None

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "table":
            self._rows = []
        elif tag == "tr":
            self._rows.append([])
        elif tag in ("td", "th"):
            self._cell = ""
        elif tag == "caption":
            self._caption = ""
        elif tag == "img":
            self.images.append(attrs)
        elif tag == "body":
            self.body = attrs
        elif tag == "dt":
            self._term = ""
        if tag in ("section", "figure", "table", "h2"):
            self.order.append(attrs.get("id", tag))
        if "id" in attrs:
            self._id = attrs["id"]
            self.ids[self._id] = ""

    def handle_endtag(self, tag):
        if tag in ("td", "th"):
            self._rows[-1].append(self._cell)
            self._cell = None
        elif tag == "table":
            self.tables[self._caption.strip()] = self._rows
            self._rows = self._caption = None
        elif tag in ("code", "span", "section"):
            self._id = None
        elif tag == "dt":
            self.terms.append(self._term)
            self._term = None

    def handle_data(self, data):
        if self._term is not None:
            self._term += data
        if self._cell is not None:
            self._cell += data
        elif self._rows is not None and self._caption is not None and not self._rows:
            self._caption += data
        if self._id:
            self.ids[self._id] += data


def browser(tmp_path: Path, *args) -> subprocess.CompletedProcess:
    """Headless Chromium on its own profile in tmp_path (skips the test when there is none)."""
    if BROWSER is None:
        pytest.skip("no headless browser: install Debian's chromium package (apt-get install chromium) to open "
                    "the HTML reports")
    return subprocess.run([BROWSER, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                           f"--user-data-dir={tmp_path / 'profile'}", "--virtual-time-budget=10000", *args],
                          capture_output=True, text=True, timeout=120)


def rendered(report: Path, tmp_path: Path, width: int | None = None) -> Tables:
    """The report as the browser renders it (its DOM after the load event), parsed; in a window `width`
    pixels wide when given."""
    page = tmp_path / f"open_{report.name}"
    page.write_text(report.read_text().replace("</body>", ONLOAD))
    size = [f"--window-size={width},900"] if width else []
    dom = browser(tmp_path, *size, "--dump-dom", page.as_uri()).stdout
    assert 'data-loaded="yes"' in dom, dom[-2000:]
    parsed = Tables()
    parsed.feed(dom)
    return parsed


def fits(report: Path, tmp_path: Path, widths=(1280, 700)) -> list[Path]:
    """Open the report at each width: nothing reaches past the page's edges (a wide table or figure scrolls in
    its own box), the page does not scroll sideways, every image decodes and is shown at READABLE of its own
    width or more (issue 38: compare's figure at 700 px was shrunk to half, its text unreadable). Keeps a screenshot of each (its first 2400
    pixels), in tmp_path; returns them."""
    shots = []
    for w in widths:
        doc = rendered(report, tmp_path, w)
        assert doc.body["data-overflow"] == "none", f"{w} px: {doc.body['data-overflow']}"
        assert int(doc.body["data-scroll-width"]) <= int(doc.body["data-page-width"]) <= w
        assert doc.images and all(int(img["data-natural-width"]) > 300 for img in doc.images)
        for img in doc.images:
            natural, shown = int(img["data-natural-width"]), float(img["data-shown-width"])
            assert shown >= READABLE * natural - 1, f"{w} px: a {natural} px figure shown {shown:.0f} px wide"
        shot = tmp_path / f"{report.stem}_{w}px.png"
        browser(tmp_path, f"--window-size={w},2400", f"--screenshot={shot}", report.as_uri())
        assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and shot.stat().st_size > 20_000
        shots.append(shot)
    return shots


def column(rows, name):
    """{first cell: the cell of column `name`} of a parsed table (header row first)."""
    j = rows[0].index(name)
    return {r[0]: r[j] for r in rows[1:]}


def check_header_and_images(doc: Tables, command: str, images: int):
    assert doc.ids["version"] == version("cvtdesign") and doc.ids["command"].startswith(command)
    assert len(doc.images) == images
    for img in doc.images:
        assert img["src"].startswith("data:image/png;base64,iVBORw0KGgo")      # the PNG signature, base64
        assert int(img["data-natural-width"]) > 300                            # and the browser decoded it


@pytest.mark.slow
def test_compare_report(tmp_path, capsys):
    report = tmp_path / "compare.html"
    assert main(["compare", str(BOX), "--out", str(tmp_path / "c"), "--json", str(tmp_path / "c.json"),
                 "--report", str(report)]) == 0
    printed = capsys.readouterr().out
    doc = rendered(report, tmp_path)
    check_header_and_images(doc, f"cvtdesign compare {BOX}", 1)
    rows = doc.tables["CVT comparison over the operating envelope (γ × τ⊥)"]
    assert rows[0] == ["figure", "ideal (box_kim)", "existing_kim", "box_kim"]
    box = column(rows, "box_kim")
    js = json.loads((tmp_path / "c.json").read_text())["variants"]
    lo, hi = js[2]["max_abs_alpha_deg_interval"]
    assert box["max |α| [°]"] == f"4.166 [{lo:.3f}, {hi:.3f}]" and box["max Hertz p [MPa]"].startswith("2.60 [")
    assert column(rows, "ideal (box_kim)")["max |α| [°]"] == "0.000"
    assert box["calibration"] == "own ε (fitted)" and box["contact law"] == "kim"
    # the same figures as the JSON and as printed
    lo, hi = js[1]["max_abs_alpha_deg_interval"]
    assert column(rows, "existing_kim")["max |α| [°]"] == f"{js[1]['max_abs_alpha_deg']:.3f} [{lo:.3f}, {hi:.3f}]" \
        == "10.761 [10.597, 10.925]"
    assert re.search(r"│ max \|α\| \[°\] +│ +0\.000 │ +10\.761 \[10\.597, 10\.925\] │ +4\.166 \[", printed)  # any widths
    # a summary in plain words first, the figure, the table, then a glossary of the figure and every row
    assert doc.order[:5] == ["summary", "h2", "h2", "figure", "h2"] and doc.order[-2:] == ["glossary", "h2"]
    assert doc.ids["summary"].startswith("SummaryLargest slip angle: existing_kim 10.761°; box_kim 4.166°. Box_kim "
                                         "slips less than existing_kim (P = 1.000)")
    assert "every operating point of every variant is ok (357 each)" in doc.ids["summary"]
    assert {r[0] for r in rows[1:]} <= set(doc.terms) and "Figure 1" in doc.terms


def test_every_row_of_compare_has_its_meaning_in_the_glossary():
    """A row added to compare's table needs its definition in the report's glossary (compare_report.MEANINGS)."""
    assert {key for key, _, _ in COLUMNS} <= set(MEANINGS)


@pytest.mark.slow
def test_compare_report_of_five_fits_any_width(tmp_path, capsys):
    """Five variants: the page fits 1280 and 700 pixels (the table scrolls in its own box), its images
    decode; the screenshots are kept."""
    report = tmp_path / "compare5.html"
    assert main(["compare", *map(str, sorted((ROOT / "variants").glob("*.yaml"))), "--out", str(tmp_path / "c"),
                 "--report", str(report), "--as-written"]) == 0
    assert len(fits(report, tmp_path)) == 2


def test_bad_report_path_refused_before_computing(tmp_path, capsys):
    assert main(["compare", str(BOX), "--out", str(tmp_path / "c"), "--report", str(tmp_path / "no" / "r.html")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"--report {tmp_path / 'no' / 'r.html'}: no folder" in err
    assert not (tmp_path / "c").exists()


@pytest.mark.slow
def test_optimise_report(tmp_path, capsys):
    """The closed-form optimum of test_optimise (d = R (2 r_s + c)/(R + r_s) = 48.80 mm) in mm, in the
    printed table and in the report."""
    study = tmp_path / "study.yaml"
    study.write_text(yaml.safe_dump({"name": "t", "base": str(BOX), "design": {"d": {"lower": "30 mm", "upper": "110 mm"}},
                                     "multistart": {"starts": 1}, "constraints": {"clearance": "2 mm", "traction_margin": None,
                                                                                  "hertz_pressure": False}}))
    report = tmp_path / "optimise.html"
    assert main(["optimise", str(study), "--out", str(tmp_path / "res"), "--json", str(tmp_path / "o.json"),
                 "--report", str(report)]) == 0
    printed = capsys.readouterr().out
    res = json.loads((tmp_path / "o.json").read_text())
    d = 0.0635 * (2 * 0.038 + 0.002) / (0.0635 + 0.038)
    assert res["design"]["d"] == pytest.approx(d, rel=1e-4) and engineering(d, "length") == "48.8 mm"
    doc = rendered(report, tmp_path)
    check_header_and_images(doc, f"cvtdesign optimise {study}", 3)
    title = f"optimum: worst |α| = {degrees(res['objective'])}"
    design = doc.tables[title]
    assert design == [["variable", "optimum", "base", "lower", "upper"], ["d", "48.8 mm", "60 mm", "30 mm", "110 mm"]]
    cons = {r[0]: r for r in doc.tables["constraints (most binding row of each; multiplier = objective change per "
                                        "unit of bound)"][1:]}
    assert cons["clearance"][2:4] == ["2 mm", "2 mm"] and cons["clearance"][6] == "yes"
    assert cons["clearance"][5].endswith(" °/mm") and cons["normal_force"][3] == "5 N"   # 5 % of the 100 N preload
    assert title in printed and "│ d        │ 48.8 mm │ 60 mm │ 30 mm │ 110 mm │" in printed
    # the summary first; the optimum beside the base design, the convergence and the slack figures; a glossary
    assert doc.order[0] == "summary" and doc.order[-2:] == ["glossary", "h2"] and len(doc.images) == 3
    summary = doc.ids["summary"]
    assert f"The optimum of study t: {title[len('optimum: '):]}" in summary and "d = 48.8 mm (base 60 mm)" in summary
    assert "1 of 1 starts reached it" in summary and "It sits on clearance" in summary
    assert {"Figure 1", "Figure 2", "Figure 3", "clearance", "normal_force", "slack", "multiplier"} <= set(doc.terms)
    assert res["details"]["history"] and res["details"]["base_envelope_check"]["max_abs_alpha_deg"] > 0
    assert len(fits(report, tmp_path)) == 2


@pytest.mark.slow
def test_diagnose_report(tmp_path, capsys):
    """Rolling resistance withheld from the model (offset 0.1 mm): the fitted offset is shown in mm, the same
    as the JSON's metres; the residual map and the fit plot are embedded without --plots."""
    layout = load_variant(EXISTING)
    proto = rig.Protocol(np.radians(np.arange(-80, 81, 20.0)), np.array([-1, -0.5, 0, 0.5, 1.0]), np.array([10.0]))
    rows, failed = rig.simulate(layout, ("drive_longitudinal_creep", "steering_lateral_creep", "rolling_resistance"),
                                {"rolling_resistance": {"offset": 1e-4}}, proto, rig.Noise(), 3)
    assert failed == {}
    data = tmp_path / "data.csv"
    data.write_text(rig.to_csv_text(rows))
    report = tmp_path / "diagnose.html"
    assert main(["diagnose", str(data), "--variant", str(EXISTING), "--base", "drive_longitudinal_creep,steering_lateral_creep",
                 "--candidates", "rolling_resistance,steering_offset", "--json", str(tmp_path / "d.json"),
                 "--report", str(report)]) == 0
    printed = capsys.readouterr().out
    rep = json.loads((tmp_path / "d.json").read_text())
    assert rep["verdict"] == "rolling_resistance"
    doc = rendered(report, tmp_path)
    check_header_and_images(doc, f"cvtdesign diagnose {data}", 2)
    assert [p.name for p in tmp_path.iterdir() if p.suffix == ".png"] == []     # no plot left behind
    fit = column(doc.tables["base model fit: drive_longitudinal_creep + steering_lateral_creep"], "value")
    for name, p in rep["base_fit"].items():
        assert fit[name] == engineering(p["value"], "dimensionless") and abs(p["value"] - 1) < 0.1
    ranking = doc.tables["candidates, each added alone to the base model (held out)"]
    fitted = column(ranking, "fitted")
    off = rep["ranking"][0]["params"]["rolling_resistance.offset"]
    assert EFFECTS["rolling_resistance"].params["offset"].kind == "length" and abs(off["value"] - 1e-4) < 1e-5
    assert fitted["rolling_resistance"] == f"offset = {value_pm(off['value'], off['std'], 'length')}"
    assert fitted["rolling_resistance"].endswith(" mm") and 0.09 <= float(fitted["rolling_resistance"].split()[2]) <= 0.11
    assert fitted["steering_offset"].startswith("offset = ") and fitted["steering_offset"].endswith("°")
    assert column(ranking, "accepted")["rolling_resistance"] == "yes"
    # one set of numbers: the share of the gap is the JSON's, in the same words, printed and in the HTML
    share = f"removes {rep['how_far']['shrink']:.0%} of the gap"
    assert rep["shares"][0]["share"] == pytest.approx(rep["how_far"]["shrink"])
    text = report.read_text()
    assert share in " ".join(printed.split()) and share in text
    assert printed.lstrip().startswith("Mostly rolling resistance: offset = ")      # the answer comes first


def test_study_summary_names_designs_in_units():
    """study's tables: each optimum's design in its units, and the knee of a Pareto front named as a design."""
    kinds = {"d": "length", "preload": "force", "r_steer": "length"}
    pts = [{"point": k, "worst_alpha_deg": a, "power_loss_W": w, "design.d": 0.0488, "design.preload": p,
            "status": "Solve_Succeeded", "success": True, "variant_file": f"/r/variants/s_pareto{k}.yaml"}
           for k, (a, w, p) in enumerate([(1.843, 5.962, 300.0), (3.058, 3.242, 132.2), (4.274, 2.622, 80.0)])]
    table, knee_note = pareto_blocks("box_pareto", pts, 1, kinds)
    assert table.headers == ["point", "worst α", "power loss", "d", "preload", "status", "variant file"]
    assert table.rows[1] == ["1", "3.058°", "3.242 W", "48.8 mm", "132.2 N", "Solve_Succeeded", "s_pareto1.yaml"]
    assert knee_note.text == "Pareto box_pareto: knee: point 1 — d = 48.8 mm, preload = 132.2 N, worst α 3.058°, loss 3.242 W"
    starts = pd.DataFrame([{"variant": "box_kim.yaml", "fixed": json.dumps({"r_steer": 0.03}), "objective": o,
                            "worst_alpha_deg": o, "power_loss_W": np.nan, "design.d": d, "variant_file": f"/r/v{i}.yaml"}
                           for i, (o, d) in enumerate([(1.807, 0.04211), (1.807, 0.04211), (2.5, 0.09)])])
    best = best_optima(starts)
    t = optima_table(best, starts, "worst_alpha", kinds)
    assert t.headers == ["variant", "sweep point", "d", "worst |α|", "power loss", "found by", "variant file"]
    assert t.rows == [["box_kim.yaml", "r_steer = 30 mm", "42.11 mm", "1.807°", "—", "2 starts", "v0.yaml"]]
    rms = optima_table(best.assign(worst_alpha_deg=2.2), starts, "rms_alpha", kinds)    # the objective is another figure
    assert rms.headers[3:5] == ["worst |α|", "RMS α"] and rms.rows[0][3:5] == ["2.2°", "1.807°"]


@pytest.mark.slow
def test_a_wide_figure_stays_readable_at_700_px(tmp_path):
    """compare's figure (960 px) at 700 px was shrunk into the page to two thirds of its width and its text could
    not be read. Now a figure is shown at READABLE of its width or more, scrolling inside its own box, and
    nothing reaches past the page's edges (`fits`); a narrow one is shown at its own width."""
    from cvtdesign.io.plots import figure_parts, save
    from cvtdesign.io.report import png_figure

    mpl = figure_parts()
    blocks = []
    for name, inches in (("wide", 12.0), ("narrow", 5.0)):
        fig, ax = mpl.subplots(figsize=(inches, 4))
        ax.plot([0, 1], [0, 1])
        ax.set_title("a title in the figure's own small print, which must stay legible")
        save(fig, tmp_path / f"{name}.png", dpi=80)
        blocks.append(png_figure(tmp_path / f"{name}.png", f"Figure: {name}"))
    report = tmp_path / "figures.html"
    report.write_text(html_report("figures", "cvtdesign compare x.yaml", "1.0", blocks))
    assert len(fits(report, tmp_path)) == 2
    doc = rendered(report, tmp_path, 700)
    assert [float(i["data-shown-width"]) for i in doc.images] == [pytest.approx(round(READABLE * 960), abs=1), 400]
