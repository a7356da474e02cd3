"""The compiled model (core.native, core.newton) gives the interpreted model's numbers, and the interpreted
model gives those of CasADi's Newton rootfinder applied to the model's equations point by point (the
solver the model has always used): α, statuses, every output and the derivatives. Also the compile policy,
the cache and the fallback without a C compiler."""
import subprocess
import sys
import time

import casadi as ca
import numpy as np
import pytest

from cvtdesign.core import native
from cvtdesign.core.model import POINT_OUTPUTS, CONTACT_OUTPUTS, compile_model, status_counts
from cvtdesign.core.newton import newton_solver
from cvtdesign.io.variant import load_spec, load_variant, resolve
from conftest import VARIANTS

SHIPPED = ("existing_kim", "box_kim", "unequal_kim", "existing", "box")
needs_compiler = pytest.mark.skipif(native.compiler() is None, reason="no C compiler on this machine")


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """An empty library cache of the test's own."""
    monkeypatch.setenv("CVTDESIGN_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


def reference(model, G, T):
    """The envelope point by point with CasADi's `newton` rootfinder on the model's residual (and on its
    steering residual for φ) and the model's output function: the numbers before the model was compiled."""
    opts = {"abstolStep": 1e-12, "error_on_fail": False, "show_eval_warnings": False}
    cvt = ca.rootfinder("ref", "newton", model.residual, opts | {"abstol": 1e-12, "max_iter": 40})
    steer = ca.rootfinder("ref_steer", "newton", model.steering_residual, opts | {"abstol": 1e-14, "max_iter": 30})
    g, t = G.ravel(), T.ravel()
    phi = np.array(steer.map(g.size)(model.steering_guess(g)[0], np.vstack([g])).full()).ravel()
    params = np.vstack([g, np.full(g.size, model.layout.motor_speed), t, 0 * g, phi,
                        np.tile(np.array(model.param_values, float)[:, None], g.size)])
    x = cvt.map(g.size)(model.initial_guess.map(g.size)(params), params)
    out = model.outputs.map(g.size)(x, params)
    return dict(zip(POINT_OUTPUTS + CONTACT_OUTPUTS, (np.array(o.full()) for o in out)))


def assert_same(res, ref, tol=1e-10):
    """Same status everywhere; every output the same to `tol` (relative above 1) at the ok points."""
    status = np.where(np.isfinite(ref["status"][0]), ref["status"][0], 1).astype(int)
    np.testing.assert_array_equal(res["status"].ravel(), status)
    ok = status == 0
    for k in POINT_OUTPUTS + CONTACT_OUTPUTS:
        if k in ("status",):
            continue
        a = res[k].reshape(ref[k].shape[0], -1)[:, ok]
        b = ref[k][:, ok]
        np.testing.assert_allclose(a, b, rtol=tol, atol=tol, err_msg=k)


@pytest.mark.slow
@needs_compiler
@pytest.mark.parametrize("name", SHIPPED)
def test_compiled_interpreted_and_rootfinder_agree_on_the_shipped_variants(name, monkeypatch):
    """Every shipped variant over its envelope: the compiled model (evaluate with CVTDESIGN_COMPILE=always,
    through the thread map), the interpreted one (never) and CasADi's rootfinder point by point give the
    same statuses, status counts and outputs to 1e-10 (in fact to the last bit)."""
    layout = load_variant(VARIANTS / f"{name}.yaml")
    G, T = np.meshgrid(layout.gamma_grid, layout.load_grid, indexing="ij")
    monkeypatch.setenv("CVTDESIGN_COMPILE", "never")
    interpreted = compile_model(layout)
    a = interpreted.evaluate(G, T)
    monkeypatch.setenv("CVTDESIGN_COMPILE", "always")
    compiled = compile_model(layout)
    b = compiled.evaluate(G, T)
    assert compiled._tiered.native is not None and interpreted._tiered.native is None
    ref = reference(interpreted, G, T)
    assert_same(a, ref)
    assert_same(b, ref)
    assert status_counts(a, interpreted.roller_names) == status_counts(b, compiled.roller_names)


def test_newton_written_out_is_casadis_newton():
    """The written-out iteration against CasADi's `newton` rootfinder on problems that need its line search
    (arctan from far away), exhaust max_iter (no real root) or stop on the step length: the same iterates to
    the last bit; and their implicit derivatives, −J⁻¹ ∂F/∂p at the root, to 1e-11 (the differentiable
    written-out solver takes them from one more Newton step with its own QR solve, the rootfinder from CasADi's:
    measured 1.5e-12 apart)."""
    x, p = ca.SX.sym("x", 2), ca.SX.sym("p", 2)
    G = ca.Function("G", [x, p], [ca.vertcat(ca.atan(x[0] - p[0]), x[1] ** 2 - p[1])])
    ref = ca.rootfinder("ref", "newton", G, {"abstol": 1e-12, "abstolStep": 1e-12, "max_iter": 40,
                                             "error_on_fail": False})
    new = newton_solver("new", G, 1e-12, 1e-12, 40)
    for x0, pv in [([5, 3], [0.2, 4]), ([-20, 0.1], [1, 2]), ([3, 1], [0, -1]), ([1e8, 1e-3], [0, 1e-9])]:
        np.testing.assert_array_equal(np.array(new(x0, pv)), np.array(ref(x0, pv)))
    differentiable = newton_solver("new_d", G, 1e-12, 1e-12, 40, derivatives=True)
    pm = ca.MX.sym("p", 2)
    jac = [ca.Function("j", [pm], [ca.jacobian(s([5, 3], pm), pm)])([0.2, 4]) for s in (ref, differentiable)]
    np.testing.assert_allclose(np.array(jac[1]), np.array(jac[0]), rtol=1e-11)


@pytest.mark.slow
@needs_compiler
def test_compiled_derivatives_match_interpreted(cache):
    """d(outputs)/d(θ, design) of the compiled library (its fwd1_/adj1_ functions, found by CasADi's
    `external`) against the interpreted model's implicit derivatives, forward and reverse: existing_kim.yaml
    with r_steer and preload as design symbols."""
    spec, path = load_spec(VARIANTS / "existing_kim.yaml"), str(VARIANTS / "existing_kim.yaml")
    p = ca.SX.sym("p", 2)
    m = compile_model(resolve(spec, path, overrides={"r_steer": p[0], "preload": p[1]}),
                      effects=["drive_longitudinal_creep", "steering_lateral_creep", "normal_force_variation"], design=p)
    lib = m.native_point(derivatives=True)
    g = np.radians([-60.0, -20.0, 10.0, 50.0])
    loads = np.array([-0.8, 0.3, 1.0, -0.2])
    th, d = ca.MX.sym("th", len(m.param_names)), ca.MX.sym("d", 2)
    jacs = []
    for fn in (m.point, lib):
        out = dict(zip(fn.name_out(), fn.map(g.size, "thread", 2)(g, 10.0, loads, 0.0, m.steering_guess(g)[0], th, d)))
        y = ca.vertcat(ca.vec(out["alpha"]), ca.vec(out["N"]), ca.vec(out["tau_2"]))
        f = ca.Function("f", [th, d], [ca.jacobian(y, ca.vertcat(th, d)), ca.jtimes(y, ca.vertcat(th, d), ca.DM.ones(y.shape), True)])
        jacs.append([np.array(o.full()) for o in f(np.array(m.param_values) * 1.05, [0.035, 120.0])])
    for a, b in zip(*jacs):
        assert np.all(np.isfinite(b)) and np.abs(b).max() > 0
        np.testing.assert_allclose(a, b, rtol=1e-8, atol=1e-8 * np.abs(b).max())


@pytest.mark.slow
@needs_compiler
def test_auto_compiles_in_a_detached_process_once_hot(cache, monkeypatch):
    """'auto': the first evaluation is interpreted and, once over HOT_SECONDS, starts a compile in another
    process; the library appears in the cache and later evaluations use it."""
    monkeypatch.setenv("CVTDESIGN_COMPILE", "auto")
    monkeypatch.setattr(native, "HOT_SECONDS", 0.0)
    m = compile_model(load_variant(VARIANTS / "existing_kim.yaml"))
    G, T = np.meshgrid(np.radians([-40.0, 0.0, 40.0]), [-0.5, 0.5], indexing="ij")
    first = m.evaluate(G, T)
    assert m._tiered.native is None and m._tiered.pending is not None
    lib = m._tiered.pending[2]
    for _ in range(600):     # the library is moved into place first, then the compiler's source removed
        if native.verified(lib) and not list(cache.glob(".source-*")):
            break
        time.sleep(0.1)
    assert native.verified(lib) and not list(cache.glob(".source-*"))
    second = m.evaluate(G, T)
    assert m._tiered.native is not None
    np.testing.assert_array_equal(first["alpha"], second["alpha"])


@needs_compiler
def test_concurrent_compiles_of_one_library_do_not_collide(cache):
    """Three processes build the same library at once: one compiles under the lock, the others wait and load
    it; one library and its sidecar, no temporary files left."""
    x = ca.SX.sym("x")
    code = native.source(ca.Function("square", [x], [x * x]))
    script = ("import sys; from cvtdesign.core import native; "
              "lib = native.build(sys.stdin.read(), native.compiler()); "
              "print(float(native.load(lib, 'square')(3.0)))")
    procs = [subprocess.Popen([sys.executable, "-c", script], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
             for _ in range(3)]
    outs = [p.communicate(code)[0].strip() for p in procs]
    assert outs == ["9.0"] * 3
    assert sorted(f.suffix for f in cache.iterdir() if not f.name.endswith(".lock")) == [".sha256", ".so"]


def test_without_a_compiler_the_model_runs_interpreted_with_one_notice(cache, monkeypatch, capsys):
    """No C compiler (CC names none): every policy evaluates interpreted, the same numbers, and says so once."""
    monkeypatch.setenv("CC", "no-such-compiler-cvtdesign")
    monkeypatch.setattr(native, "_noticed", set())
    monkeypatch.setenv("CVTDESIGN_COMPILE", "always")
    m = compile_model(load_variant(VARIANTS / "existing_kim.yaml"))
    g = np.radians([-30.0, 30.0])
    a = m.evaluate(g, 0.5)
    b = m.evaluate(g, 0.5)
    assert m.native_point() is None and m._tiered.native is None
    err = capsys.readouterr().err.splitlines()
    assert err == ["cvtdesign: no C compiler found (set CC): the model runs interpreted, several times slower"]
    monkeypatch.setenv("CVTDESIGN_COMPILE", "never")
    np.testing.assert_array_equal(a["alpha"], compile_model(m.layout).evaluate(g, 0.5)["alpha"])
    np.testing.assert_array_equal(a["alpha"], b["alpha"])
    assert not cache.exists()


def test_a_failing_compiler_falls_back_with_its_error(cache, monkeypatch, capsys):
    """A compiler that fails (here `false`): interpreted, one notice naming it."""
    monkeypatch.setenv("CC", "false")
    monkeypatch.setattr(native, "_noticed", set())
    monkeypatch.setenv("CVTDESIGN_COMPILE", "always")
    m = compile_model(load_variant(VARIANTS / "existing_kim.yaml"))
    m.evaluate(np.radians([10.0]), 0.2)
    m.evaluate(np.radians([10.0]), 0.2)
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("cvtdesign: compiling the model failed, it runs interpreted: false failed")
    assert m._tiered.native is None


def test_cache_folder_and_policy_from_the_environment(monkeypatch, tmp_path, capsys):
    monkeypatch.delenv("CVTDESIGN_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert native.cache_dir() == tmp_path / "xdg" / "cvtdesign"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path))
    assert native.cache_dir() == tmp_path / ".cache" / "cvtdesign"
    monkeypatch.setenv("CVTDESIGN_CACHE", str(tmp_path / "mine"))
    assert native.cache_dir() == tmp_path / "mine"
    monkeypatch.setattr(native, "_noticed", set())
    monkeypatch.setenv("CVTDESIGN_COMPILE", "sometimes")
    assert native.policy() == "auto"
    assert "CVTDESIGN_COMPILE='sometimes' is not one of auto, always, never" in capsys.readouterr().err


@needs_compiler
def test_a_run_that_announces_many_evaluations_waits_for_the_compiled_function(cache, monkeypatch):
    """'auto': evaluations announced (Tiered.expect) past WAIT_SECONDS interpreted make the first call compile
    and wait (a diagnosis's ~900 evaluations of its rows); without the announcement the first call of the
    same size stays interpreted."""
    monkeypatch.setenv("CVTDESIGN_COMPILE", "auto")
    x = ca.SX.sym("x")
    fn = ca.Function("announced", [x], [ca.sin(x) * x])
    quiet, told = native.Tiered(fn, lambda: fn), native.Tiered(fn, lambda: fn)
    assert quiet.function(10) is fn and quiet.pending is None
    told.expect(int(native.WAIT_SECONDS / told.per_point) + 1)
    compiled = told.function(10)
    assert compiled is not fn and told.native is compiled
    assert float(compiled(0.5)) == float(fn(0.5))


@needs_compiler
def test_start_compiles_beside_the_process_and_switches_once_the_library_is_there(cache, monkeypatch):
    """Tiered.start under 'auto': a detached compile at once, however little the function was used; the
    calls stay interpreted until the library is in the cache, then use it."""
    monkeypatch.setenv("CVTDESIGN_COMPILE", "auto")
    x = ca.SX.sym("x")
    fn = ca.Function("started", [x], [ca.cos(x) * x])
    tier = native.Tiered(fn, lambda: fn)
    tier.start()
    assert tier.pending is not None and tier.native is None
    lib = tier.pending[2]
    for _ in range(600):
        if native.verified(lib):
            break
        time.sleep(0.1)
    assert tier.function(1) is not fn and float(tier.native(0.3)) == float(fn(0.3))
