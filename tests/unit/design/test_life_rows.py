"""constraints.min_life_h (design/life_rows.py): every roller's wear life over a duty cycle, as rows of the
study's NLP, against the life chain (core.life.wear) on the model's own contacts."""
from __future__ import annotations


import numpy as np
import pytest
import yaml

from conftest import ROOT, shipped_model

from cvtdesign.core.life import wear
from cvtdesign.core.life.run import machine_life
from cvtdesign.design.problem import build_problem
from cvtdesign.design.solve import solve_from, starts
from cvtdesign.design.study_file import load_study
from cvtdesign.errors import InputError
from cvtdesign.io.ageing import roller_ageing
from cvtdesign.io.duty_file import load_duty
from cvtdesign.io.variant import load_spec

STUDY = ROOT / "studies" / "box_placement_life.yaml"


def test_life_rows_are_the_wear_life_at_the_base_design():
    """At the base design (box_kim.yaml) the row of roller i is L_min over the wear life `cvtdesign life` gives
    it: L_min · Σ_k s_k k P_f,k/(4π r b_k) / (1 % r), with the model's losses and patch at the duty points at
    the rollers' consistent temperatures (core.life.run: the heat's feedback on the creep), not at the air's."""
    pr = build_problem(load_study(STUDY))
    z = (pr.base_values - pr.lower) / (pr.upper - pr.lower)
    g = np.asarray(pr.evaluate(np.append(z, 4.0))[1]).ravel()
    life = np.array([f == "life" for f in pr.g_family])
    model, duty = shipped_model("box_kim"), load_duty(ROOT / "studies" / "cobot_duty.yaml")
    ages = roller_ageing(str(ROOT / "variants/box_kim.yaml"), load_spec(ROOT / "variants/box_kim.yaml"), model.roller_names)
    warm = machine_life(model, duty, [ages[n] for n in model.roller_names])
    expected = [60000 * 3600 / c.lives["wear"] for c in warm.contacts]
    np.testing.assert_allclose(g[life], expected, rtol=1e-6)
    res = model.evaluate(duty.gamma, duty.load, speeds=duty.speed)       # at the air's temperature: shorter rows
    cold = [60000 * 3600 * float(duty.shares @ wear.wear_rate(ages[r.name][0]["wear_coefficient"], res["loss"][i],
                                                               r.radius, res["b"][i])) / (0.01 * r.radius)
            for i, r in enumerate(model.layout.rollers)]
    assert np.all(np.asarray(cold) < g[life])
    assert pr.g_ub[life].tolist() == [1.0] * len(expected) and "N1" in pr.g_labels[np.flatnonzero(life)[4]]


@pytest.mark.slow
def test_life_constraint_binds_and_costs_slip():
    """The placement optimum takes the smallest steering rollers (20 mm), whose wear life on the cobot task is
    about 27 000 h; with min_life_h 60 000 h the optimum keeps larger ones, at a higher worst |α|."""
    pr = build_problem(load_study(STUDY))
    sol = solve_from(pr, starts(pr)[0])
    life = np.array([f == "life" for f in pr.g_family])
    assert np.max(sol.g[life]) == pytest.approx(1.0, abs=1e-6)
    free = build_problem(load_study(ROOT / "studies" / "box_placement_kim.yaml"))
    base = solve_from(free, starts(free)[0])
    assert sol.objective > base.objective and sol.design["r_steer"] > base.design["r_steer"] + 1e-3
    readme = (ROOT / "README.md").read_text()     # the README's figures are these
    assert f"worst |α| {base.objective:.4g}°" in readme and f"worst |α| {sol.objective:.3g}°" in readme
    assert f"{1e3 * sol.design['r_steer']:.3g} mm rollers" in readme


def test_min_life_needs_its_duty(tmp_path):
    data = yaml.safe_load(STUDY.read_text())
    data["base"] = str(ROOT / "variants" / "box_kim.yaml")
    del data["constraints"]["life_duty"]
    f = tmp_path / "s.yaml"
    f.write_text(yaml.safe_dump(data))
    with pytest.raises(InputError, match="constraints.life_duty: missing"):
        build_problem(load_study(f))


def test_min_life_is_a_time(tmp_path):
    data = yaml.safe_load(STUDY.read_text())
    data["base"] = str(ROOT / "variants" / "box_kim.yaml")
    data["constraints"]["life_duty"] = str(ROOT / "studies" / "cobot_duty.yaml")
    data["constraints"]["min_life_h"] = "60000 N"
    f = tmp_path / "s.yaml"
    f.write_text(yaml.safe_dump(data))
    with pytest.raises(InputError, match="constraints.min_life_h: expected a time"):
        build_problem(load_study(f))


@pytest.mark.slow
def test_duty_travels_as_content(tmp_path):
    """A study's workers read no input file: the duty file travels as data (design.cases.study_content), which
    gives the same life rows with the file gone; an edited duty file is a new study (its digest)."""
    import shutil

    from cvtdesign.design.cases import make_cases, study_content
    from cvtdesign.design.study_file import Study, load_study
    from cvtdesign.io.duty_file import duty_from_data, inline
    duty = load_duty(ROOT / "studies" / "cobot_duty.yaml")
    back = duty_from_data(inline(duty), "x")
    for a in ("gamma", "load", "speed", "seconds"):
        np.testing.assert_allclose(getattr(back, a), getattr(duty, a), rtol=1e-15)
    assert (back.ambient, back.hub_ratio, back.wear_limit, back.name) == (duty.ambient, duty.hub_ratio, None, duty.name)
    data = yaml.safe_load(STUDY.read_text())
    data["base"] = str(ROOT / "variants" / "box_kim.yaml")
    shutil.copy(ROOT / "studies" / "cobot_duty.yaml", tmp_path / "cobot_duty.yaml")
    f = tmp_path / "s.yaml"
    f.write_text(yaml.safe_dump(data))
    study = load_study(f)
    content = study_content(study, make_cases(study))
    assert isinstance(content.spec.constraints.life_duty, dict)
    rows = lambda pr: np.asarray(pr.evaluate(np.append(np.full(3, 0.5), 4.0))[1]).ravel()[  # noqa: E731
        np.array([fam == "life" for fam in pr.g_family])]
    from_file = rows(build_problem(study))
    (tmp_path / "cobot_duty.yaml").unlink()
    np.testing.assert_allclose(rows(build_problem(Study(f, content.spec, study.base))), from_file, rtol=1e-12)   # shares: 1 ulp
    shutil.copy(ROOT / "studies" / "cobot_duty.yaml", tmp_path / "cobot_duty.yaml")
    edited = yaml.safe_load((tmp_path / "cobot_duty.yaml").read_text())
    edited["ambient"] = "30 degC"
    (tmp_path / "cobot_duty.yaml").write_text(yaml.safe_dump(edited))
    assert study_content(study, make_cases(study)).digest != content.digest


def _max_life_study(tmp_path, **constraints):
    data = yaml.safe_load(STUDY.read_text())
    data.update(name="maxlife", base=str(ROOT / "variants" / "box_kim.yaml"), objective={"kind": "max_life"})
    data["constraints"].pop("min_life_h")
    data["constraints"]["life_duty"] = str(ROOT / "studies" / "cobot_duty.yaml")
    data["constraints"].update(constraints)
    data["constraints"] = {k: v for k, v in data["constraints"].items() if v is not None}
    f = tmp_path / "maxlife.yaml"
    f.write_text(yaml.safe_dump(data))
    return f


@pytest.mark.slow
def test_max_life_objective_is_the_worst_inverse_life(tmp_path):
    """Objective max_life: the p-norm (p = 32) of the rollers' inverse wear lives [1/h], between the largest
    and 8^(1/32) times it, the largest being the life rows' over min_life_h."""
    pr = build_problem(load_study(_max_life_study(tmp_path)))
    z = (pr.base_values - pr.lower) / (pr.upper - pr.lower)
    f = float(pr.evaluate(z)[0])
    rows = build_problem(load_study(STUDY))
    g = np.asarray(rows.evaluate(np.append(z, 4.0))[1]).ravel()[np.array([fam == "life" for fam in rows.g_family])]
    worst = np.max(g) / 60000.0                   # [1/h]: rows are min_life_h × the inverse life
    assert worst <= f <= 8 ** (1 / 32) * worst
    assert 1 / worst == pytest.approx(75800, rel=0.03)     # life's 75 800 h on the box (with its feedback)


def test_max_life_needs_its_duty(tmp_path):
    with pytest.raises(InputError, match="life_duty: missing.*max_life"):
        build_problem(load_study(_max_life_study(tmp_path, life_duty=None)))


@pytest.mark.slow
def test_max_life_keeps_larger_steering_rollers(tmp_path, cli):
    """On the box the longest-lived placement keeps the steering rollers at the envelope's limit (40 mm)."""
    code, out, err = cli("optimise", _max_life_study(tmp_path), "--out", tmp_path / "o")
    assert code == 0, err
    assert "1/h (life" in out
    assert "40 mm" in [line.split("│")[2].strip() for line in out.splitlines() if "r_steer" in line][0]
