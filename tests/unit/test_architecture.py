"""The package's structure, read from its source with `ast` (nothing is imported or run).

- Layers: a subpackage imports only from the layers below it (LAYERS), so the import graph has no cycle.
- No function or method is longer than MAX_FUNCTION_LINES.
- Imports sit at the top of each module; only the heavy optional libraries (LAZY) are imported inside a
  function, and each of those in one module only (its boundary).
- No private name (`_x`) is imported from another module.
- Nothing in the package, docs/, the README, the shipped variants or the studies points at a file outside
  the repository.
"""
from __future__ import annotations

import ast
import re
from collections import defaultdict
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PKG = ROOT / "cvtdesign"
MAX_FUNCTION_LINES = 80
# each layer may import from itself and the layers listed for it
LAYERS = {
    "errors": set(),
    "core": {"errors"},
    "io": {"errors", "core"},
    "design": {"errors", "core", "io"},
    "cad": {"errors", "core", "io"},
    "diagnosis": {"errors", "core", "io", "design"},
    "cli": {"errors", "core", "io", "design", "cad", "diagnosis"},
    "__main__": {"cli"},
}
LAZY = {"cadquery", "OCP", "matplotlib"}   # heavy optional imports (OCP is CadQuery's kernel): inside functions, at one boundary each


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
