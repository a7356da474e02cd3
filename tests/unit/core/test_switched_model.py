"""A switched model (core.model.compile_model, switched: every effect with a switch in θ, core.effects.SWITCH)
gives each subset of its effects the numbers of that subset's own model, whatever the parameters of the
effects switched off: the diagnosis's candidates are all fitted with one such model."""
import numpy as np
import pytest

from cvtdesign.core.contact.laws import candidates
from cvtdesign.core.effects import EFFECTS, KIM_MODEL, SWITCH, parameter_vector
from cvtdesign.core.model import compile_model
from conftest import shipped_layout

OUTPUTS = ("alpha", "omega_2", "tau_1", "tau_2", "gamma_axis", "N", "F_t", "F_a", "utilisation", "steering_torque")
# the solves' linear algebra is ordered by the Jacobian's sparsity, which the switched terms widen: the same
# solution to round-off, amplified by the rigid directions' conditioning (measured: 4e-12 relative in α on
# existing_kim, 1e-9 in the scaled unknowns)
RTOL = 1e-8


def switched_theta(model, on: tuple, off_values: dict) -> np.ndarray:
    """The switched model's θ with the effects `on` switched on at their defaults and every other effect
    switched off, its parameters at `off_values` (far from their defaults: they must not matter)."""
    theta = np.array(model.param_values, float)
    for i, n in enumerate(model.param_names):
        effect = n.split(SWITCH)[0].split(".")[0]
        if n.endswith(SWITCH):
            theta[i] = float(effect in on)
        elif effect not in on:
            theta[i] = off_values[n]
    return theta


@pytest.mark.parametrize("name", ["existing_kim", pytest.param("existing", marks=pytest.mark.slow)])
def test_each_subset_of_a_switched_model_is_its_own_model(name):
    layout = shipped_layout(name)
    every = tuple(e for e in EFFECTS if e in candidates(layout.contact_law))
    switched = compile_model(layout, every, switched=True)
    assert switched.param_names == parameter_vector(every, switched=True)[0]
    # the switched-off effects' parameters far from their defaults, inside their bounds
    off = {}
    for n in switched.param_names:
        if not n.endswith(SWITCH):
            e, p = n.split(".")
            spec = EFFECTS[e].params[p]
            off[n] = spec.default * 3 if spec.upper >= spec.default * 3 else (spec.default + spec.upper) / 2
    G, T = np.meshgrid(np.radians([-60.0, -20.0, 0.0, 30.0, 70.0]), [-1.0, -0.3, 0.4, 1.0], indexing="ij")
    subsets = [KIM_MODEL[:1], KIM_MODEL] + [KIM_MODEL[:1] + (e,) for e in every if e not in KIM_MODEL]
    for on in subsets:
        own = compile_model(layout, on)
        a = own.evaluate(G, T)
        b = switched.evaluate(G, T, theta=switched_theta(switched, on, off))
        np.testing.assert_array_equal(a["status"], b["status"], err_msg=str(on))
        assert a["ok"].sum() >= 15, on
        for k in OUTPUTS:
            scale = np.nanmax(np.abs(a[k]))
            np.testing.assert_allclose(b[k], a[k], rtol=RTOL, atol=RTOL * scale, err_msg=f"{on}: {k}")


def test_a_switched_off_effect_with_every_hook_kind_changes_nothing():
    """Every kind of hook (transform: steering angle, rolling radius, creep normal, friction; collect:
    compliance, saturation, resistance) switched off at parameters that would change the model a lot: the
    base model's numbers; switched on, the numbers move (the switch does switch)."""
    layout = shipped_layout("existing_kim")
    every = tuple(e for e in EFFECTS if e in candidates(layout.contact_law))
    hooks = {h for e in every for h in EFFECTS[e].hooks}
    assert {"steering_angle", "rolling_radius", "creep_normal", "friction", "compliance", "saturation",
            "resistance"} <= hooks
    switched = compile_model(layout, every, switched=True)
    G, T = np.meshgrid(np.radians([-30.0, 10.0, 50.0]), [-0.8, 0.6], indexing="ij")
    off = {n: v for n, v in zip(switched.param_names, switched.param_values)}
    theta = switched_theta(switched, KIM_MODEL, off)
    base = compile_model(layout, KIM_MODEL).evaluate(G, T)
    b = switched.evaluate(G, T, theta=theta)
    np.testing.assert_allclose(b["alpha"], base["alpha"], rtol=RTOL, atol=RTOL * np.nanmax(np.abs(base["alpha"])))
    for e in every:
        if e in KIM_MODEL:
            continue
        on = theta.copy()
        on[switched.param_names.index(e + SWITCH)] = 1.0
        moved = switched.evaluate(G, T, theta=on)
        assert np.nanmax(np.abs(moved["alpha"] - base["alpha"])) > 1e-9, e
