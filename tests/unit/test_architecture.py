"""The package's structure, read from its source with `ast` (nothing is imported or run, except where said).

- Layers: a subpackage imports only from the layers below it (LAYERS), so the import graph has no cycle.
- No function or method is longer than MAX_FUNCTION_LINES, no module longer than MAX_MODULE_LINES.
- Each kind of change has one place: effects are named only in core/effects.py (and the laws and the
  independent simulator), contact laws only in core/contact/laws.py; every effect entry is complete; a toy
  effect and a toy law, each added in its one place, work end to end (these tests import the package).
- Imports sit at the top of each module; only the heavy optional libraries (LAZY) are imported inside a
  function, and each of those in one module only (its boundary).
- No private name (`_x`) is imported from another module.
- Nothing in the package, docs/, the README, the shipped variants or the studies points at a file outside
  the repository.
"""
from __future__ import annotations

import ast
import math
import re
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
PKG = ROOT / "cvtdesign"
MAX_FUNCTION_LINES = 80
MAX_MODULE_LINES = 450
# each layer may import from itself and the layers listed for it
LAYERS = {
    "errors": set(),
    "core": {"errors"},
    "io": {"errors", "core"},
    "design": {"errors", "core", "io"},
    "cad": {"errors", "core", "io"},
    "diagnosis": {"errors", "core", "io", "design"},
    "verification": {"errors", "core", "io", "design", "diagnosis"},
    "uses": {"errors", "core", "io", "design", "cad", "diagnosis", "verification"},
    "api": {"errors", "core", "io", "design", "cad", "diagnosis", "verification", "uses"},
    "cli": {"errors", "core", "io", "design", "cad", "diagnosis", "verification", "uses"},
    "__main__": {"cli"},
}
LAZY = {"cadquery", "OCP", "matplotlib",   # heavy optional imports (OCP is CadQuery's kernel): inside functions,
        "pandas", "scipy"}                    # at one boundary each (pandas, SciPy: where compare would load them)


def modules() -> dict[str, ast.Module]:
    out = {}
    for path in sorted(PKG.rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = ast.parse(path.read_text(), str(path))
    return out


MODULES = modules()


def imported(node) -> list[str]:
    """The modules an import statement names (absolute imports only: the package uses no relative ones)."""
    if isinstance(node, ast.Import):
        return [a.name for a in node.names]
    assert node.level == 0, f"relative import on line {node.lineno}"
    return [node.module] + [f"{node.module}.{a.name}" for a in node.names]


def layer(module: str) -> str:
    return module.split(".")[1] if "." in module else "errors"


def test_package_is_grouped_in_layers():
    top = {m.split(".")[1] for m in MODULES if m.count(".") >= 1}
    assert top <= set(LAYERS), f"modules outside the layers: {sorted(top - set(LAYERS))}"


@pytest.mark.parametrize("module", sorted(MODULES))
def test_imports_only_from_lower_layers(module):
    own = layer(module) if module != "cvtdesign" else None
    for node in ast.walk(MODULES[module]):
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            for name in imported(node):
                if name.startswith("cvtdesign.") and name.split(".")[1] in LAYERS or name == "cvtdesign.errors":
                    target = layer(name)
                    assert own is None or target == own or target in LAYERS[own], \
                        f"{module} (layer {own}) imports {name} (layer {target}), line {node.lineno}"


def test_no_import_cycles():
    graph = defaultdict(set)
    for module, tree in MODULES.items():
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                graph[module] |= {n for n in imported(node) if n in MODULES and n != module}
    seen, stack = {}, []

    def visit(m):
        seen[m] = "open"
        stack.append(m)
        for n in sorted(graph[m]):
            if seen.get(n) == "open":
                raise AssertionError("import cycle: " + " -> ".join(stack[stack.index(n):] + [n]))
            if n not in seen:
                visit(n)
        stack.pop()
        seen[m] = "done"

    for m in sorted(MODULES):
        if m not in seen:
            visit(m)


def test_no_long_functions():
    long = [f"{m}.{n.name} ({n.end_lineno - n.lineno + 1} lines)" for m, tree in MODULES.items()
            for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))
            and n.end_lineno - n.lineno + 1 > MAX_FUNCTION_LINES]
    assert not long, f"functions over {MAX_FUNCTION_LINES} lines: {long}"


def test_no_long_modules():
    long = {str(p.relative_to(ROOT)): n for p in sorted(PKG.rglob("*.py"))
            if (n := len(p.read_text().splitlines())) > MAX_MODULE_LINES}
    assert not long, f"modules over {MAX_MODULE_LINES} lines: {long}"


def test_imports_at_the_top_except_heavy_optional_ones():
    inner, boundary = [], defaultdict(set)
    for m, tree in MODULES.items():
        top = set(map(id, tree.body))
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)) and id(node) not in top:
                roots = {n.split(".")[0] for n in imported(node)}
                if roots <= LAZY:
                    for r in roots:
                        boundary[r].add(m)
                else:
                    inner.append(f"{m} line {node.lineno}: {sorted(roots)}")
    assert not inner, f"imports inside functions: {inner}"
    assert all(len(ms) == 1 for ms in boundary.values()), f"heavy imports at more than one boundary: {dict(boundary)}"


def test_no_private_names_imported_across_modules():
    bad = [f"{m} line {n.lineno}: {n.module}.{a.name}" for m, tree in MODULES.items() for n in ast.walk(tree)
           if isinstance(n, ast.ImportFrom) and (n.module or "").startswith("cvtdesign")
           for a in n.names if a.name.startswith("_")]
    assert not bad, f"private names imported: {bad}"


def test_nothing_points_outside_the_repository():
    pattern = re.compile(r"\.\./shared|\bDESIGN\b|\brefs/|/work/")
    files = [*PKG.rglob("*.py"), *(ROOT / "docs").rglob("*.md"), ROOT / "README.md",
             *(ROOT / "variants").glob("*.yaml"), *(ROOT / "studies").glob("*.yaml")]
    bad = [f"{p.relative_to(ROOT)}:{i}" for p in files for i, line in enumerate(p.read_text().splitlines(), 1)
           if pattern.search(line)]
    assert not bad, f"references to files outside the repository: {bad}"


# --- each kind of change in one place ----------------------------------------------------------------------

# the modules that may name an effect or a contact law by its string: the vocabulary itself, the laws (which
# say which effects they contain), and the independent simulator (which writes every effect a second time, in
# its own forms, by design)
EFFECT_HOMES = {"cvtdesign.core.effects", "cvtdesign.core.contact.laws", "cvtdesign.verification.independent_sim",
                "cvtdesign.verification.independent_rig"}
LAW_HOMES = {"cvtdesign.core.contact.laws"}


def _names_used(tree: ast.Module, names: set) -> list[int]:
    """Lines where a string constant (not a docstring) is one of `names`."""
    docs = {id(n.body[0].value) for n in ast.walk(tree)
            if isinstance(n, (ast.Module, ast.ClassDef, ast.FunctionDef)) and ast.get_docstring(n) is not None}
    return [n.lineno for n in ast.walk(tree)
            if isinstance(n, ast.Constant) and n.value in names and id(n) not in docs]


def test_effects_and_laws_are_named_in_one_place():
    """No module outside the homes compares or picks an effect or a law by its name: adding one touches its
    home only (the toy tests below add one each)."""
    from cvtdesign.core.contact.laws import LAWS
    from cvtdesign.core.effects import EFFECTS
    bad = [f"{m}:{line} names an effect" for m, tree in MODULES.items() if m not in EFFECT_HOMES
           for line in _names_used(tree, set(EFFECTS))]
    bad += [f"{m}:{line} names a contact law" for m, tree in MODULES.items() if m not in LAW_HOMES
            for line in _names_used(tree, set(LAWS))]
    assert not bad, bad


def test_every_effect_entry_is_complete():
    """An effect's whole description is its entry: parameters with finite bounds and a kind of quantity, hooks
    of the hook table, the self-check's values (within the bounds), weak value and pairs, whether it acts at
    zero load, and its parameter in the independent simulator (which must have it, in the vocabulary)."""
    from cvtdesign.core import effects as fx
    from cvtdesign.io.units import KINDS
    from cvtdesign.verification import independent_sim
    for name, e in fx.EFFECTS.items():
        assert e.name == name and e.doc and e.params, name
        for p in e.params.values():
            assert p.kind in KINDS and math.isfinite(p.lower) and math.isfinite(p.upper), (name, p)
            assert p.lower <= p.default <= p.upper, (name, p)
        assert e.hooks and set(e.hooks) <= set(fx.HOOKS), (name, set(e.hooks) - set(fx.HOOKS))
        check = e.selfcheck
        param = e.params[check.param]
        values = [*(check.values or ()), *([check.weak] if check.weak is not None else [])]
        assert check.values is None or len(check.values) == 2, name
        assert all(param.lower <= v <= param.upper and (v > param.lower or not param.positive) for v in values), name
        assert set(check.told_from) <= set(fx.EFFECTS) - {name}, name
        assert isinstance(e.at_zero_load, bool), name
        assert independent_sim.EFFECTS[name][0] == e.independent and independent_sim.EFFECTS[name][3], name
    assert all(f"| `{h}` |" in fx.__doc__ for h in fx.HOOKS), "a hook missing from the hook table"


def _toy_variant(tmp_path, **changes) -> Path:
    import yaml
    data = yaml.safe_load((ROOT / "variants" / "existing_kim.yaml").read_text())
    data.update(changes)
    path = tmp_path / "toy.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def test_a_toy_effect_is_one_entry(tmp_path, monkeypatch):
    """An effect added as one entry of core.effects.EFFECTS (and nowhere else) is read from a variant file
    with its parameter checked against its bounds, changes the compiled model as its hook says, is a candidate
    of the diagnosis, gets the self-check's cases and the papers' zero-load class, and is in the reference."""
    from cvtdesign.core import effects as fx
    from cvtdesign.core.contact import laws
    from cvtdesign.core.model import compile_model
    from cvtdesign.errors import InputError
    from cvtdesign.io import reference
    from cvtdesign.io.variant import load_variant
    from cvtdesign.verification import selfcheck
    toy = fx.Effect("toy_gain", "The linkage turns by (1 + gain)·φ.",
                    {"gain": fx.Param(0.01, "dimensionless", "relative gain error", -0.1, 0.1)},
                    {"steering_angle": lambda phi, p: phi * (1 + p["gain"])},
                    fx.SelfCheck("gain", (0.01, -0.02), told_from=("steering_offset",)),
                    at_zero_load=True, independent="gain")
    monkeypatch.setitem(fx.EFFECTS, "toy_gain", toy)
    monkeypatch.setenv("CVTDESIGN_COMPILE", "never")
    effects = ["drive_longitudinal_creep", "steering_lateral_creep"]
    plain = load_variant(_toy_variant(tmp_path, effects=effects))
    L = load_variant(_toy_variant(tmp_path, effects=effects + ["toy_gain"], effect_parameters={"toy_gain": {"gain": 0.05}}))
    assert L.effect_parameters["toy_gain"] == {"gain": 0.05}
    g = np.radians([-30.0, 20.0])
    a, b = compile_model(plain).evaluate(g, 0.0), compile_model(L).evaluate(g, 0.0)
    np.testing.assert_allclose(b["phi"], a["phi"] * 1.05, rtol=1e-9)
    with pytest.raises(InputError, match="toy_gain.gain"):
        load_variant(_toy_variant(tmp_path, effects=effects + ["toy_gain"], effect_parameters={"toy_gain": {"gain": 0.5}}))
    assert "toy_gain" in laws.candidates("kim")
    assert ("steering_offset", "toy_gain") in selfcheck.pairs()
    cases = selfcheck.make_cases(matrices=("rig",))
    assert {c["id"] for c in cases if c["withheld"] == ["toy_gain"]} == {
        f"single-toy_gain-gain={v:.4g}-noise{k:g}" for v in (0.01, -0.02) for k in selfcheck.NOISE_SCALES}
    assert "### `toy_gain`" in reference.effects_markdown()


def test_a_toy_contact_law_is_one_class(tmp_path, monkeypatch):
    """A contact law added as one class of core.contact.laws (registered in LAWS, nowhere else) is accepted
    by a variant file's contact.law, compiles, and changes the model as its class says."""
    from cvtdesign.core.contact import laws
    from cvtdesign.core.model import compile_model
    from cvtdesign.io.variant import load_variant

    class StiffLaw(laws.KimLaw):
        """Kim's law with the theory's compliances halved."""
        name = "toy_stiff"

        def constants(self, layout, roller):
            c = super().constants(layout, roller)
            return {**c, "eps0": c["eps0"] / 2}

    monkeypatch.setitem(laws.LAWS, "toy_stiff", StiffLaw())
    monkeypatch.setenv("CVTDESIGN_COMPILE", "never")
    kim = load_variant(_toy_variant(tmp_path))
    kim_pairs = {"drive": ["urethane_82A", "bowling_ball"], "steering": ["urethane_84A", "bowling_ball"]}
    stiff = load_variant(_toy_variant(tmp_path, contact={"law": "toy_stiff", "creep_drive": "0.0038 1/N",
                                                         "creep_steering": "0.0049 1/N", "creep_reference_force": "100 N",
                                                         "fitted_on": kim_pairs}))
    assert stiff.contact_law == "toy_stiff"
    g = np.radians([-30.0, 20.0])
    a, b = compile_model(kim).evaluate(g, 0.5), compile_model(stiff).evaluate(g, 0.5)
    assert a["ok"].all() and b["ok"].all()
    np.testing.assert_allclose(b["alpha"], a["alpha"] / 2, rtol=0.05)
    assert laws.contact_law("toy_stiff").compliance(stiff, stiff.rollers[0]) == pytest.approx(
        laws.contact_law("kim").compliance(kim, kim.rollers[0]) / 2)


def test_core_receives_no_schema_objects():
    """core is handed SI values in its own dataclasses (core.layout), never the parsed variant file: no core
    module imports io or pydantic, names a schema class (`...Spec`) or reads a `.spec`, and no class of core
    has a field `spec` (Layout once carried the io.schema.VariantSpec down as `spec: object`)."""
    bad = []
    for m, tree in MODULES.items():
        if layer(m) != "core":
            continue
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                bad += [f"{m} line {node.lineno}: imports {n}" for n in imported(node)
                        if n.startswith(("cvtdesign.io", "pydantic"))]
            elif isinstance(node, ast.Name) and node.id.endswith("Spec") or isinstance(node, ast.Attribute) \
                    and (node.attr == "spec" or node.attr.endswith("Spec")):
                bad.append(f"{m} line {node.lineno}: names {ast.unparse(node)}")
            elif isinstance(node, ast.ClassDef):
                bad += [f"{m} line {f.lineno}: {node.name}.spec" for f in node.body
                        if isinstance(f, ast.AnnAssign) and isinstance(f.target, ast.Name) and f.target.id == "spec"]
    assert not bad, f"schema objects in core: {bad}"
