"""Objectives are classes (design.objectives): every kind is in the study file's schema, and each is one
class and one registry entry that the problem, optimise's tables, the study's table and the report read."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from conftest import ROOT

from cvtdesign.design.objectives import OBJECTIVES
from cvtdesign.design.solve import knee


def pareto_study(folder: Path, kind="pareto") -> Path:
    data = yaml.safe_load((ROOT / "studies/box_pareto.yaml").read_text())
    data.update(base=str(ROOT / "variants/box_kim.yaml"), objective={"kind": kind}, pareto={"points": 3})
    data["envelope"] = {"gamma": {"start": "-60 deg", "stop": "60 deg", "step": "60 deg"},
                        "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "1 N*m"}}
    data.pop("batch")
    path = folder / "p.yaml"
    path.write_text(yaml.safe_dump(data, allow_unicode=True))
    return path


def test_every_kind_is_in_the_schema(tmp_path, cli):
    """The schema lists the registry's kinds; another kind is one line that lists them all."""
    path = pareto_study(tmp_path, kind="slip")
    code, out, err = cli("optimise", path, "--out", tmp_path / "o")
    assert code == 2 and err.count("\n") == 1 and "objective.kind" in err
    assert all(k in err for k in OBJECTIVES)


@pytest.mark.slow
def test_a_pareto_objective_gives_the_front_and_its_knee(tmp_path, cli):
    """objective kind pareto (before: only inside the code): optimise computes the slip/loss front and writes
    its knee as the optimum, the front in the JSON (worst |α| rising as the loss falls)."""
    code, out, err = cli("optimise", pareto_study(tmp_path), "--out", tmp_path / "o", "--json", tmp_path / "o.json")
    assert code == 0, err
    res = json.loads((tmp_path / "o.json").read_text())["details"]
    front = [p for p in res["front"] if p["status"] == "Solve_Succeeded"]
    assert len(front) == 3
    assert np.all(np.diff([p["worst_alpha_deg"] for p in front]) > 0)
    assert np.all(np.diff([p["power_loss_W"] for p in front]) < 0)
    k = knee([dict(p, index=i, success=True) for i, p in enumerate(front)])
    assert res["objective"] == front[k]["power_loss_W"] and res["objective_kind"] == "pareto"
    assert "the slip/loss front, 3 points" in " ".join(out.split()) and Path(res["variant_file"]).is_file()


def test_the_design_code_calls_the_objective_not_its_flags():
    """What the design code does for an objective is a method of the objective (inputs, add_rows, solves,
    power_loss): no design module outside design/objectives.py reads `eps_row` or `case_column` (design/study.py
    compared `case_column == "power_loss_W"`, four modules tested `eps_row`)."""
    import ast
    read = [f"{f.name} line {n.lineno}: .{n.attr}" for f in sorted((ROOT / "cvtdesign" / "design").glob("*.py"))
            if f.name != "objectives.py" for n in ast.walk(ast.parse(f.read_text()))
            if isinstance(n, ast.Attribute) and n.attr in ("eps_row", "case_column")]
    assert not read, read


def test_each_kind_says_what_a_case_runs(tmp_path):
    """The front's objective runs its ε chain and no starts; the others their starts, and the chain with
    batch.pareto; the store's power loss is the objective only where the objective is that power loss."""
    from cvtdesign.design.cases import make_cases
    from cvtdesign.design.study_file import load_study
    assert OBJECTIVES["pareto"].solves(4, False) == (0, True)
    assert [OBJECTIVES[k].solves(4, p) for k in ("worst_alpha", "power_loss") for p in (False, True)] == \
        [(4, False), (4, True)] * 2
    assert OBJECTIVES["power_loss"].power_loss(1.5) == OBJECTIVES["pareto"].power_loss(1.5) == 1.5
    assert all(np.isnan(OBJECTIVES[k].power_loss(1.5)) for k in ("worst_alpha", "rms_alpha", "max_life"))
    cases = make_cases(load_study(pareto_study(tmp_path)))
    assert [c["kind"] for c in cases] == ["pareto"]
    data = yaml.safe_load((tmp_path / "p.yaml").read_text()) | {"objective": {"kind": "power_loss"},
                                                                 "multistart": {"starts": 2}, "batch": {"pareto": True}}
    (tmp_path / "p.yaml").write_text(yaml.safe_dump(data, allow_unicode=True))
    assert [c["kind"] for c in make_cases(load_study(tmp_path / "p.yaml"))] == ["start", "start", "pareto"]
