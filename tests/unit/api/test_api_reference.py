"""docs/python-api-reference.md is generated from the API's docstrings and up to date; every public name has a
numpydoc docstring that documents each of its parameters and what it returns, with units."""
import inspect
import re

import pytest

from conftest import ROOT

from cvtdesign import api
from cvtdesign.api import reference


def test_the_reference_is_up_to_date():
    committed = (ROOT / "docs" / reference.REFERENCE).read_text(encoding="utf-8")
    assert committed == reference.reference_markdown(), \
        "docs/python-api-reference.md is out of date with the docstrings: run `python -m cvtdesign.api.reference`"


def test_every_public_name_is_in_the_reference():
    text = reference.reference_markdown()
    names = reference.public_names()
    assert set(names) >= {"load_variant", "evaluate", "compare", "capacity", "Comparison", "Capacity", "Result"}
    for name in names:
        assert re.search(rf"^## (class )?`{name}[`(]", text, re.MULTILINE), name


@pytest.mark.parametrize("name", [n for n in reference.public_names() if not inspect.isclass(getattr(api, n))])
def test_each_function_documents_its_parameters_returns_and_units(name):
    fn = getattr(api, name)
    _, found = reference.sections(inspect.getdoc(fn))
    documented = {item.split(" : ")[0].lstrip("*") for item, _ in found.get("Parameters", [])}
    assert documented == set(inspect.signature(fn).parameters), name
    assert found.get("Returns") and found.get("Raises"), name
    assert re.search(r"\[(°|N·m|rad/s|m|N|-|MPa|W|%)\]", inspect.getdoc(fn)), f"{name}: no unit in its docstring"


@pytest.mark.parametrize("name", [n for n in reference.public_names() if inspect.isclass(getattr(api, n))])
def test_each_result_class_documents_its_interface(name):
    cls = getattr(api, name)
    assert inspect.getdoc(cls)
    for member in ("table", "to_json", "plot", "content"):
        assert inspect.getdoc(getattr(cls, member)), (name, member)
