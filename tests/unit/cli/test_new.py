"""`cvtdesign new`: a commented variant from each shipped template that `compare` reads with the template's
figures, a comment from the schema on every field it uses, and nothing overwritten or half-written."""
import json
import os
import re
import typing

import pytest

from cvtdesign.cli import main
from cvtdesign.io.reference import nested_model
from cvtdesign.io.schema import Spherical, VariantSpec
from cvtdesign.io.variant import load_spec
from cvtdesign.io.shipped import SHIPPED, shipped_variant
from cvtdesign.io.yaml_file import load_yaml


def used_fields(model, data: dict, out: set) -> set:
    """(model, field) of every schema field a variant's data uses."""
    for name, value in data.items():
        out.add((model, name))
        annotation = model.model_fields[name].annotation
        nested = ("model", Spherical) if isinstance(value, dict) and Spherical in typing.get_args(annotation) \
            else nested_model(annotation)
        if nested is None:
            continue
        shape, sub = nested
        items = [value] if shape == "model" else value.values() if shape == "dict" else value
        for item in items:
            used_fields(sub, item, out)
    return out


def comment_blocks(text: str) -> list[tuple[str, str]]:
    """(comment text, the key on the line right after it) for every block of comment lines."""
    blocks, current = [], []
    for line in text.splitlines():
        stripped = line.strip()
        if stripped.startswith("#"):
            current.append(stripped[1:].strip())
            continue
        m = re.match(r"(?:- )?([A-Za-z_]\w*):", stripped)
        if current and m:
            blocks.append((" ".join(current), m[1]))
        current = []
    return blocks


@pytest.mark.slow
@pytest.mark.parametrize("template", SHIPPED)
def test_compare_reads_it_with_the_templates_figures(template, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["new", "mine", "--template", template]) == 0
    assert "wrote mine.yaml" in capsys.readouterr().out
    # the same machine: every value as the template's, the name set
    mine, theirs = load_spec(tmp_path / "mine.yaml"), load_spec(shipped_variant(template))
    assert mine.name == "mine" and mine.model_dump() == theirs.model_dump() | {"name": "mine"}
    assert main(["compare", "mine.yaml", str(shipped_variant(template)), "--out", str(tmp_path / "plots"),
                 "--json", str(tmp_path / "f.json")]) == 0
    a, b = json.loads((tmp_path / "f.json").read_text())["variants"]
    assert (a["name"], b["name"]) == ("mine", template)
    assert a["max_abs_alpha_deg"] > 1      # a real CVT that slips (box 4.166°, existing 10.761°, unequal 12.254°)
    for key in ("max_abs_alpha_deg", "rms_alpha_deg", "max_abs_alpha_steering_deg", "min_efficiency",
                "max_hertz_pressure_MPa"):
        assert a[key] == pytest.approx(b[key], rel=0, abs=1e-9), key
    assert a["ok"] == b["ok"] == b["points"]


@pytest.mark.parametrize("template", SHIPPED)
def test_every_field_used_carries_its_schema_comment(template, tmp_path):
    out = tmp_path / "v.yaml"
    assert main(["new", "v", "--template", template, "--out", str(out)]) == 0
    text = out.read_text(encoding="utf-8")
    used = used_fields(VariantSpec, load_yaml(shipped_variant(template)), set())
    assert len(used) >= 30      # the shipped files use 30 (existing, unequal) to 48 (box_kim) fields
    blocks = comment_blocks(text)
    for model, name in used:
        description = model.model_fields[name].description
        assert (description, name) in blocks, f"{model.__name__}.{name}: no comment above it"
    # the template's notes on its parameters are kept; nothing points at files outside the repository
    assert re.search(r"r_steer: 38 mm +# steering roller radius", text)
    assert not re.search(r"refs/|DESIGN\.md|studies/", text)


def test_existing_target_and_bad_names_are_refused(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "taken.yaml").write_text("keep me\n")
    assert main(["new", "taken"]) == 2
    assert main(["new", "other", "--out", "taken.yaml"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == ["cvtdesign: error: taken.yaml: already exists; expected a new file name (another NAME or "
                   "--out FILE; cvtdesign new never overwrites a file)"] * 2
    assert (tmp_path / "taken.yaml").read_text() == "keep me\n"
    for bad in ("../evil", ".hidden", "a b", "x" * 101):
        assert main(["new", bad]) == 2
        line = capsys.readouterr().err
        assert line.startswith("cvtdesign: error: NAME: expected a name of letters, digits") and line.count("\n") == 1
    with pytest.raises(SystemExit) as exit_:                      # argparse: one line, status 2
        main(["new", "ok", "--template", "nosuch"])
    assert exit_.value.code == 2 and "invalid choice: 'nosuch'" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["taken.yaml"]     # nothing else written


def test_written_with_mode_0644_under_umask_022(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    old = os.umask(0o022)
    try:
        assert main(["new", "m"]) == 0
    finally:
        os.umask(old)
    assert oct(os.stat(tmp_path / "m.yaml").st_mode & 0o777) == oct(0o644)


@pytest.mark.slow
@pytest.mark.parametrize("count", [2, 3, 4])
def test_steering_n_writes_a_layout_that_shows_and_compares(count, tmp_path, monkeypatch, capsys):
    """`new --steering N`: the box's drive rollers with N steering rollers at the poles on forks about z
    (docs/linkages.md); the layout passes every check, `show` draws it, `compare` solves every point, a
    comment from the schema sits above each field it uses; with four it is the box CVT itself."""
    monkeypatch.chdir(tmp_path)
    assert main(["new", "mine", "--steering", str(count)]) == 0
    assert f"from the 'box' template with {count} steering rollers" in capsys.readouterr().out
    data = load_yaml(tmp_path / "mine.yaml")
    steering = [n for n, r in data["rollers"].items() if r["role"] == "steering"]
    assert len(steering) == count and sorted(n for f in data["steering"]["forks"] for n in f["rollers"]) == sorted(steering)
    blocks = comment_blocks((tmp_path / "mine.yaml").read_text(encoding="utf-8"))
    for model, name in used_fields(VariantSpec, data, set()):
        assert (model.model_fields[name].description, name) in blocks, f"{model.__name__}.{name}: no comment above it"
    assert main(["show", "mine.yaml", "--out", "shown"]) == 0
    assert (tmp_path / "shown/mine_layout.png").exists()
    assert main(["compare", "mine.yaml", "--out", "plots", "--json", "f.json"]) == 0
    mine = next(v for v in json.loads((tmp_path / "f.json").read_text())["variants"] if v["name"] == "mine")
    assert mine["ok"] == mine["points"] == 17 * 21
    assert 1 < mine["max_abs_alpha_deg"] < 10        # slips less than Kim's existing CVT (10.761°)
    if count == 4:
        assert mine["max_abs_alpha_deg"] == pytest.approx(4.207, abs=5e-4)      # the box CVT's figure


def test_steering_n_refused_outside_what_it_builds(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["new", "five", "--steering", "5"]) == 2
    assert main(["new", "three", "--steering", "3", "--template", "existing_kim"]) == 2
    assert capsys.readouterr().err.splitlines() == [
        "cvtdesign: error: --steering: 5 steering rollers; expected one of 2, 3, 4 (a pair or one roller at each "
        "pole; other linkages: docs/linkages.md)",
        "cvtdesign: error: --steering: builds on the box template (drive and follower rollers whose preloads "
        "balance on their own), not 'existing_kim'; expected --template box or no --template"]
    assert not list(tmp_path.iterdir())
