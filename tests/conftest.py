"""Shared fixtures: the repository's paths, the shipped variants loaded and compiled once, the CLI run
in-process, and a writer of modified variant files.

Layouts are frozen dataclasses and compiled models are only evaluated (never changed) by the tests, so both
are session-scoped: each shipped variant is read once and compiled once (with its own effects) per run.
Plain functions (`shipped_layout`, `shipped_model`) give the same cached objects to module-level code and
to hypothesis tests, which may not take function-scoped fixtures.
"""
from __future__ import annotations

import copy
import functools
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
VARIANTS = ROOT / "variants"
SHIPPED = ("existing_kim", "box_kim", "unequal_kim")
# the tests' helper modules, importable from every folder: tests/ (figure_checks, layout_transforms) and
# tests/validation (Kim's closed forms, the reference model, FASTSIM)
for _helpers in (ROOT / "tests", ROOT / "tests" / "validation"):
    if str(_helpers) not in sys.path:
        sys.path.insert(0, str(_helpers))


def variant_path(name: str) -> Path:
    """The shipped variant file variants/<name>.yaml."""
    return VARIANTS / f"{name}.yaml"


@functools.cache
def shipped_layout(name: str):
    """The shipped variant's Layout (cached: one read per session)."""
    from cvtdesign.io.variant import load_variant
    return load_variant(variant_path(name))


@functools.cache
def shipped_model(name: str, effects: tuple | None = None):
    """The shipped variant compiled with `effects` (a tuple; None: the variant's own), once per session."""
    from cvtdesign.core.model import compile_model
    return compile_model(shipped_layout(name), effects=effects)


def variant_data(name: str) -> dict:
    """The shipped variant file as a dict (a fresh copy, to edit)."""
    return copy.deepcopy(_variant_data(name))


@functools.cache
def _variant_data(name: str) -> dict:
    return yaml.safe_load(variant_path(name).read_text())


def write_yaml(path: Path, data: dict) -> Path:
    path.write_text(yaml.safe_dump(data, sort_keys=False, allow_unicode=True))
    return path


# module fixtures that take seconds to build (a study run, a tolerance study, a STEP export, a kalker run with
# --points, a life run with its intervals, capacity searches on both laws): a test that uses one is a slow check (-m slow), as the tests marked slow themselves are
SLOW_FIXTURES = {"finished", "exported", "kalker_points", "life_run", "envelopes"}


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    for item in items:
        if SLOW_FIXTURES & set(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session")
def root() -> Path:
    """The repository root."""
    return ROOT


@pytest.fixture(scope="session")
def variants() -> dict:
    """{name: path} of the shipped variants (existing, box, unequal)."""
    return {n: variant_path(n) for n in SHIPPED}


@pytest.fixture(scope="session")
def existing_layout():
    return shipped_layout("existing_kim")


@pytest.fixture(scope="session")
def box_layout():
    return shipped_layout("box_kim")


@pytest.fixture(scope="session")
def unequal_layout():
    return shipped_layout("unequal_kim")


@pytest.fixture(scope="session")
def existing_model():
    """variants/existing_kim.yaml compiled with its own effects (Kim's two creeps)."""
    return shipped_model("existing_kim")


@pytest.fixture
def cli(capsys):
    """run(*argv) → (exit status, stdout, stderr) of `cvtdesign argv`, in-process."""
    from cvtdesign.cli import main

    def run(*argv):
        capsys.readouterr()
        rc = main([str(a) for a in argv])
        out, err = capsys.readouterr()
        return rc, out, err
    return run


@pytest.fixture
def make_variant(tmp_path):
    """make(name, edit=None, file=None) → path of the shipped variant `name`, changed by edit(data) (which edits
    the dict in place; its return value is ignored), written to tmp_path/<file or name>.yaml."""
    def make(name: str = "existing_kim", edit=None, file: str | None = None) -> Path:
        data = variant_data(name)
        if edit is not None:
            edit(data)
        return write_yaml(tmp_path / f"{file or name}.yaml", data)
    return make
