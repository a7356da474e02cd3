"""The user docs agree with the code: the generated reference pages are up to date and cover every field,
range, effect and parameter; the tutorial's variant and the measured-data example give the numbers the
pages quote."""
import json
import re
import typing

import numpy as np
import pytest
import yaml
from pydantic import BaseModel

from conftest import ROOT

from cvtdesign.cli import main
from cvtdesign.core.effects import EFFECTS
from cvtdesign.core.kinematics import shaft_frame
from cvtdesign.diagnosis.measured import from_rows
from cvtdesign.io import reference
from cvtdesign.io.measured_csv import read_measured
from cvtdesign.io.schema import VariantSpec, unit_text
from cvtdesign.io.variant import PLAUSIBLE, load_variant
from cvtdesign.io.shipped import shipped_variant

DOCS = ROOT / "docs"
OWN = ["variant-reference.md", "effects.md", "measured-data.md", "adding-an-effect.md", "writing-a-variant.md"]


def models_of(annotation) -> list[type]:
    """Every schema model an annotation names, however deeply (unions, lists, mappings, Annotated)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [m for a in typing.get_args(annotation) for m in models_of(a)]


def all_models(model=VariantSpec, seen=None) -> list[type]:
    seen = [] if seen is None else seen
    if model not in seen:
        seen.append(model)
        for info in model.model_fields.values():
            for sub in models_of(info.annotation):
                all_models(sub, seen)
    return seen


@pytest.mark.parametrize("name", sorted(reference.generated_docs()))
def test_generated_docs_are_up_to_date(name):
    committed = (DOCS / name).read_text(encoding="utf-8")
    assert committed == reference.generated_docs()[name], \
        f"docs/{name} is out of date with the code: run `.venv/bin/python -m cvtdesign.io.reference`"


def test_every_schema_field_is_in_the_reference():
    text = (DOCS / "variant-reference.md").read_text(encoding="utf-8")
    models = all_models()
    assert {m.__name__ for m in models} >= {"VariantSpec", "MaterialSpec", "SphereSpec", "RollerSpec",
                                            "RollerDefaults", "ForkSpec", "SteeringSpec", "ContactSpec",
                                            "RangeSpec", "EnvelopeSpec", "FrameSpec", "Spherical"}
    for model in models:
        for name, info in model.model_fields.items():
            assert info.description, f"{model.__name__}.{name} has no description"
            kind = (info.json_schema_extra or {}).get("kind")
            meaning = info.description.removesuffix("; " + unit_text(kind)) if kind else info.description
            assert re.search(rf"`[^`]*\b{name}`", text), f"{model.__name__}.{name}: no row in the reference"
            assert meaning.replace("|", "\\|") in text, f"{model.__name__}.{name}: meaning missing"
    # the paths of the fields users write most, spelled out
    for path in ("rollers.<roller>.radius", "roller_defaults.mount_stiffness", "steering.forks[].sign",
                 "envelope.gamma.step", "materials.<material>.youngs_modulus", "frame.distance"):
        assert f"| `{path}` |" in text


def test_every_plausible_range_is_documented_on_its_field():
    fields = {(info.json_schema_extra or {}).get("plausible") for m in all_models() for info in m.model_fields.values()}
    assert set(PLAUSIBLE) <= fields, f"ranges no field documents: {set(PLAUSIBLE) - fields}"
    text = (DOCS / "variant-reference.md").read_text(encoding="utf-8")
    assert "| `sphere.radius` | number or quantity | m; e.g. 40 mm | **required** | 1 mm ≤ value ≤ 2 m" in text
    assert "100 kPa ≤ value ≤ 1200 GPa" in text and "did you mean '45 mm'?" in text


def test_every_effect_and_parameter_is_in_the_effects_page():
    text = (DOCS / "effects.md").read_text(encoding="utf-8")
    for name, effect in EFFECTS.items():
        section = text.split(f"### `{name}`")[1].split("### ")[0]
        assert " ".join(effect.doc.split()) in section
        for hook in effect.hooks:
            assert f"`{hook}`" in section
        for p, spec in effect.params.items():
            assert f"| `{p}` |" in section and spec.doc in section
    assert "| `offset` | m; e.g. 40 mm | `0.0001 m (0.1 mm)` | 0 < value ≤ 0.005 m (5 mm) |" in text


def yaml_blocks(name: str) -> list[str]:
    return re.findall(r"```yaml\n(.*?)```", (DOCS / name).read_text(encoding="utf-8"), re.S)


@pytest.mark.slow
def test_tutorial_variant_gives_the_figures_it_quotes(tmp_path):
    text = (DOCS / "writing-a-variant.md").read_text(encoding="utf-8")
    full = [b for b in yaml_blocks("writing-a-variant.md") if b.startswith("name:")]
    assert len(full) == 1 and "# ..." not in full[0]
    (tmp_path / "small.yaml").write_text(full[0])
    assert main(["compare", str(tmp_path / "small.yaml"), str(shipped_variant("existing")),
                 "--out", str(tmp_path / "plots"), "--json", str(tmp_path / "f.json")]) == 0
    small, existing = sorted(json.loads((tmp_path / "f.json").read_text())["variants"], key=lambda r: r["name"] != "small")
    m = re.search(r"max \|α\| (\S+)° \((\S+)° of it at the steering rollers, (\S+)° at the drive rollers\), worst\s+"
                  r"efficiency (\S+), max traction utilisation F/\(μN\) (\S+) and Hertz peak pressure (\S+) MPa",
                  " ".join(text.split()))
    quoted = [float(x) for x in m.groups()]
    got = [small[k] for k in ("max_abs_alpha_deg", "max_abs_alpha_steering_deg", "max_abs_alpha_drive_deg",
                              "min_efficiency", "max_traction_utilisation", "max_hertz_pressure_MPa")]
    assert np.allclose(quoted, got, rtol=0, atol=6e-3), (quoted, got)
    assert f"against {existing['max_abs_alpha_deg']:.3f}°, {existing['min_efficiency']:.3f}" in " ".join(text.split())
    assert small["ok"] == small["points"] == 187
    # the plate of section 3 fits this variant
    data = yaml.safe_load(full[0]) | {"frame": {"side": "-z", "distance": "90 mm", "thickness": "10 mm"}}
    (tmp_path / "framed.yaml").write_text(yaml.safe_dump(data))
    assert load_variant(tmp_path / "framed.yaml").name == "small"


def test_measured_data_example_gives_the_derived_values_it_quotes(tmp_path):
    text = (DOCS / "measured-data.md").read_text(encoding="utf-8")
    csv = re.search(r"```csv\n(.*?)```", text, re.S)[1]
    (tmp_path / "ex.csv").write_text(csv)
    rows, dropped = read_measured(tmp_path / "ex.csv")
    m = from_rows(rows, shaft_frame(load_variant(shipped_variant("existing_kim"))))
    table = re.findall(r"^\| (\d) \| (\S+) \| (\S+) \| (\S+) \| (\S+) \| (\d) \|$", text, re.M)
    assert [int(r[0]) for r in table] == [2, 3, 4]
    for (line, alpha, tperp, tpar, eff, point), (_, row) in zip(table, m.rows.iterrows()):
        num = [float(x.replace("−", "-")) for x in (alpha, tperp, tpar, eff)]
        assert np.allclose(num, [row.alpha_deg, row.tau_perp, row.tau_par, row.efficiency], rtol=0, atol=6e-4)
        assert int(point) == row.point
    # Kim's layout, r1 = r2: α = atan2(ω2, ω1) − γ
    assert m.rows.alpha_deg[0] == pytest.approx(np.degrees(np.arctan2(4.51016611, 10.0084408)) - 30, abs=1e-9)


@pytest.mark.parametrize("name", OWN)
def test_docs_name_only_docs_that_exist(name):
    text = (DOCS / name).read_text(encoding="utf-8")
    for ref in set(re.findall(r"docs/([\w-]+\.md)", text)):
        assert (DOCS / ref).exists(), f"docs/{name} names docs/{ref}, which does not exist"


@pytest.mark.slow
def test_readme_compare_table_is_what_compare_prints(tmp_path, monkeypatch):
    """The README's table of the three shipped variants is the table `compare` prints for them, cell by cell
    (two interval ends had gone stale: 0.41 for 0.40, 93.81 for 93.80)."""
    from cvtdesign.cli.compare import COLUMNS, figure_cell
    monkeypatch.chdir(ROOT)
    js = tmp_path / "c.json"
    files = [f"variants/{n}.yaml" for n in ("existing", "box", "unequal")]
    assert main(["compare", *files, "--out", str(tmp_path / "p"), "--json", str(js)]) == 0
    rows = {r["name"]: r for r in json.loads(js.read_text())["variants"]}
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    table = text[text.index("| figure (95 % interval from every input we know of) | existing | box | unequal |"):]
    lines = [ln for ln in table.splitlines()[2:] if ln.startswith("|")][:9]
    assert len(lines) == 9
    for line, (key, _, fmt) in zip(lines, COLUMNS):
        cells = [c.strip() for c in line.strip("|").split("|")][-3:]
        assert cells == [figure_cell(rows[n], key, fmt) for n in ("existing", "box", "unequal")], (key, line)
