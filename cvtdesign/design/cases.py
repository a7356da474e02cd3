"""A study's cases, planned and checked before anything runs (design.study runs them): every base variant
(`batch.variants`, default the study's `base`) × every combination of the swept fixed parameters
(`batch.sweep`) × every multistart point (`multistart.starts`), plus, with `batch.pareto`, one
ε-constraint Pareto chain per variant × sweep combination; and the study's content as it travels to the
workers (`StudyContent`: the spec and each variant file's text, never a path)."""
from __future__ import annotations

import hashlib
import itertools
import json
import math
from dataclasses import dataclass
from pathlib import Path

from cvtdesign.design.life_rows import life_duty
from cvtdesign.design.objectives import objective
from cvtdesign.design.study_file import (
    Study,
    StudySpec,
    StudyVariant,
    check_counts,
    next_to,
    problem_inputs,
    study_variant,
)
from cvtdesign.errors import InputError
from cvtdesign.io.duty_file import inline
from cvtdesign.io.variant import parameter_value

MAX_CASES = 10_000       # cases of one study (variant files × sweep points × starts): more is a typo, and
                         # checking them all before any runs would take minutes



@dataclass(frozen=True)
class StudyContent:
    """A study as it travels to the workers, read and checked in this process: `path` the study file as
    this process names it (in messages and provenance only: no worker opens it), `digest` its study_hash,
    `spec` the study, `variants` each variant file of its cases by the path the cases name it by."""
    path: str
    digest: str
    spec: StudySpec
    variants: dict[str, StudyVariant]


def study_hash(study_file: Path, spec, base: Path) -> str:
    """Hash of the study file, of every variant file it names and of its calibration report (so an edited
    variant or a new fit is a new study)."""
    h = hashlib.sha256(Path(study_file).read_bytes())
    for v in variant_files(study_file, spec, base):
        h.update(v.read_bytes())
    if spec.calibration:
        h.update((Path(study_file).parent / spec.calibration).read_bytes())
    if spec.constraints.life_duty is not None:          # its duty cycle as the workers get it
        h.update(json.dumps(_duty_data(study_file, spec), sort_keys=True).encode())
    return h.hexdigest()[:16]


def _duty_data(study_file, spec) -> dict:
    """constraints.life_duty as data (a file read and resolved here: its task log too)."""
    return inline(life_duty(spec, str(study_file))) if isinstance(spec.constraints.life_duty, str) \
        else spec.constraints.life_duty


def variant_files(study_file, spec, base) -> list[Path]:
    if not spec.batch.variants:
        return [base]
    files = [next_to(study_file, "batch.variants", v) for v in spec.batch.variants]
    stems: dict = {}
    for v, f in zip(spec.batch.variants, files):
        if f.stem in stems and f.resolve() != stems[f.stem][1].resolve():
            raise InputError(f"{study_file}: batch.variants: '{stems[f.stem][0]}' and '{v}' have the same name "
                             f"'{f.stem}', which names their cases and result files; expected variant files with "
                             "different names")
        stems[f.stem] = (v, f)
    return files


def make_cases(study: Study) -> list[dict]:
    """The study's cases (study_file.load_study), each a small picklable dict with a stable id."""
    study_file, spec, base = study.path, study.spec, study.base
    check_counts(str(study_file), spec)
    for k, vals in spec.batch.sweep.items():
        if not vals:
            raise InputError(f"{study_file}: batch.sweep.{k}: no values; expected at least one (or leave it out)")
    files = variant_files(study_file, spec, base)
    n_starts, chain = objective(spec.objective.kind).solves(spec.multistart.starts, spec.batch.pareto)
    per_case = n_starts + chain
    total = len(files) * math.prod(len(v) for v in spec.batch.sweep.values()) * per_case
    if total > MAX_CASES:
        raise InputError(f"{study_file}: batch: {len(files)} variant files × the sweep × {spec.multistart.starts} starts "
                         f"make {total} cases; expected at most {MAX_CASES}")
    sweep = {k: [parameter_value(v, f"{study_file}: batch.sweep.{k}", {}) for v in vals] for k, vals in spec.batch.sweep.items()}
    combos = [dict(zip(sweep, vals)) for vals in itertools.product(*sweep.values())] or [{}]
    cases = []
    for vf in files:
        for fixed in combos:     # in names a variant file reads back: letters, digits, '_', '.', '+', '-'
            tag = "_".join(f"{k}{v:.6g}" for k, v in fixed.items())
            stem = vf.stem + (f"_{tag}" if tag else "")
            for k in range(n_starts):
                cases.append({"id": f"{stem}_start{k}", "kind": "start", "variant": str(vf), "fixed": fixed, "start": k})
            if chain:
                cases.append({"id": f"{stem}_pareto", "kind": "pareto", "variant": str(vf), "fixed": fixed, "start": 0})
    return cases


def study_content(study: Study, cases: list[dict]) -> StudyContent:
    """What the workers get (StudyContent): every variant file of `cases` read once here
    (study_file.study_variant: one InputError line for a bad one)."""
    study_file, spec, base = study.path, study.spec, study.base
    variants = {}
    for c in cases:
        if c["variant"] not in variants:
            variants[c["variant"]] = study_variant(study_file, spec, Path(c["variant"]))
    digest = study_hash(study_file, spec, base)
    if spec.constraints.life_duty is not None:      # the duty file's content travels, not its path
        spec = spec.model_copy(update={"constraints": spec.constraints.model_copy(
            update={"life_duty": _duty_data(study_file, spec)})})
    return StudyContent(str(study_file), digest, spec, variants)


def check_study(content: StudyContent, cases: list[dict]) -> None:
    """Every distinct problem's inputs (variant file × sweep point), checked before any case is submitted,
    from what the workers will get: one InputError line for the first bad one (study_file.problem_inputs)."""
    seen = set()
    for c in cases:
        key = (c["variant"], json.dumps(c["fixed"], sort_keys=True))
        if key not in seen:
            seen.add(key)
            problem_inputs(content.path, content.spec, content.variants[c["variant"]], c["fixed"])
