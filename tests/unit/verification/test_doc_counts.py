"""The counts the README and docs/diagnosis.md quote of the self-check's matrices (datasets, single cases,
nulls, pairs, cases outside the vocabulary) are the code's (verification.selfcheck.case_counts): adding an
effect or a case fails here until the docs say the new numbers, and the independent rig's table of
visibilities (a comment at independent_rig.CASES) has a row for every case that withholds something."""
import re
from pathlib import Path

import pytest

from cvtdesign.verification import independent_rig
from cvtdesign.verification.selfcheck import case_counts

ROOT = Path(__file__).resolve().parents[3]
FULL, QUICK = case_counts(), case_counts(quick=True)


def total(counts, matrix=None) -> int:
    return sum(n for (m, _), n in counts.items() if matrix in (None, m))


# (file, pattern whose groups are counts, the code's values of those groups)
CLAIMS = [
    ("README.md", r"`cvtdesign selfcheck --quick` \((\d+) datasets\)", [total(QUICK)]),
    ("README.md", r"full `cvtdesign selfcheck` \((\d+) datasets\)", [total(FULL)]),
    ("README.md", r"top-1 \d+/(\d+) on the rig matrix, and \d+/(\d+) on the independent one",
     [FULL["rig", "single"], FULL["independent", "single"]]),
    ("README.md", r"outside the vocabulary: \d+/(\d+) `unexplained`", [FULL["independent", "out_of_vocabulary"]]),
    ("README.md", r"the quick matrices since give the\s+same: \d+/(\d+) right", [total(QUICK)]),
    ("docs/diagnosis.md", r": (\d+) single sets, (\d+) null sets, (\d+) weak\s+effects .*?, (\d+) pairs",
     [FULL["rig", k] for k in ("single", "null", "weak", "pair")]),
    ("docs/diagnosis.md", r"Measured \(`cvtdesign selfcheck`, (\d+) datasets", [total(FULL)]),
    ("docs/diagnosis.md", r"Rig: top-1 \d+/(\d+), null false positives \d+/(\d+), weak effects \d+/(\d+) right, "
                          r"pairs \d+/(\d+)\. Independent: top-1 \d+/(\d+),\s+nulls \d+/(\d+), outside the "
                          r"vocabulary \d+/(\d+)",
     [FULL["rig", k] for k in ("single", "null", "weak", "pair")]
     + [FULL["independent", k] for k in ("single", "null", "out_of_vocabulary")]),
    ("docs/diagnosis.md", r"--quick`, (\d+) datasets", [total(QUICK)]),
    ("docs/diagnosis.md", r"rig top-1 \d+/(\d+) .*?, nulls \d+/(\d+) named,", [QUICK["rig", "single"], QUICK["rig", "null"]]),
    ("docs/diagnosis.md", r"independent top-1 \d+/(\d+) .*?outside the vocabulary \d+/(\d+)",
     [QUICK["independent", "single"], QUICK["independent", "out_of_vocabulary"]]),
    ("docs/diagnosis.md", r"--variant variants/box.yaml`, (\d+) datasets\)", [total(FULL, "rig")]),
    ("docs/diagnosis.md", r"null false positives \d+/(\d+), pairs \d+/(\d+)\. Its saturation",
     [FULL["rig", "null"], FULL["rig", "pair"]]),
]


@pytest.mark.parametrize("path, pattern, expected", CLAIMS, ids=[f"{c[0]}:{c[1][:30]}" for c in CLAIMS])
def test_the_docs_quote_the_code_s_counts(path, pattern, expected):
    text = " ".join((ROOT / path).read_text().split())
    found = [list(map(int, m.groups())) for m in re.finditer(" ".join(pattern.split()), text, re.S)]
    assert found, f"{path}: no text matches {pattern!r} (reworded? update the claim here)"
    assert all(f == expected for f in found), f"{path}: {pattern!r} quotes {found}, the code has {expected}"


def test_the_visibility_table_has_every_case():
    """independent_rig's comment table of visibilities lists every case that withholds something."""
    source = (ROOT / "cvtdesign/verification/independent_rig.py").read_text()
    rows = set(re.findall(r"^#   (\S+-\S+)\s+[\d.]", source, re.M))
    assert {c["id"] for c in independent_rig.CASES if c["truth"] != "none"} == rows


def test_a_new_case_changes_the_counts(monkeypatch):
    """The counts follow the code: one more independent case outside the vocabulary is one more."""
    extra = dict(independent_rig.CASES[0], id="toy-clear", truth="unexplained")
    monkeypatch.setattr(independent_rig, "CASES", [*independent_rig.CASES, extra])
    assert case_counts(matrices=("independent",))["independent", "out_of_vocabulary"] == \
        FULL["independent", "out_of_vocabulary"] + 1
