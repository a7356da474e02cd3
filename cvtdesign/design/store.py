"""The results store of a batch study (design.study) or a tolerance study (design.tolerance).

Store (`results/<study>/` by default): `cases/<case id>.parquet`, one file per finished case written
atomically (a Parquet dataset readable with pandas/pyarrow as a whole), `variants/` the designs as variant
files, and `manifest.json` (study hash, package versions, solver options). Re-running the same command
skips the cases already in the store, so a killed study loses nothing it had finished; a store made by a
different study file (another hash) is refused. Each case's status is recorded: IPOPT's status
(Solve_Succeeded, Infeasible_Problem_Detected, Maximum_Iterations_Exceeded, ...), `worker_crashed`, or
`error: ...`; nothing is swallowed. A case stored as `worker_crashed` or `error: ...` says what happened to
the run, not to the design, so the next run runs it again. Every file goes through output.write_files
(atomic, umask's mode), in this process only: a case's file and its optimum's variant files together.
"""
from __future__ import annotations

import contextlib
import json
from importlib import metadata
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
from filelock import FileLock, Timeout

from cvtdesign.design.problem import IPOPT_OPTIONS
from cvtdesign.errors import InputError
from cvtdesign.io.output import OutputError, make_folder, write_file, write_files


# the columns every case file has (besides design.<variable>)
CASE_COLUMNS = ("case_id", "kind", "variant", "fixed", "start", "point", "status", "success", "objective",
                "worst_alpha_deg", "power_loss_W", "iterations", "variant_file", "seconds", "reason")


# statuses that say what happened to the run, not to the design: such a case runs again on the next run
RUN_FAILURES = ("worker_crashed", "error: ")


def failure_rows(case: dict, status: str) -> list[dict]:
    return [{"case_id": case["id"], "kind": case["kind"], "variant": Path(case["variant"]).name,
             "fixed": json.dumps(case["fixed"]), "start": case["start"], "point": 0, "status": status,
             "success": False, "objective": np.nan, "worst_alpha_deg": np.nan, "power_loss_W": np.nan,
             "iterations": 0, "variant_file": None, "seconds": np.nan, "reason": status}]


def write_case(out_dir: Path, case_id: str, rows: list[dict], files: dict | None = None):
    """One Parquet file per case, with the case's variant files `files` ({path: text}, from run_case), all
    or nothing by output.write_files (pyarrow writes the temporary file, which is then renamed: never
    half-written); pyarrow directly, a third of pandas' time, which matters in the client that also runs
    the scheduler."""
    table = pa.Table.from_pylist(rows)
    d = make_folder(Path(out_dir) / "cases", kind="results store")
    if files:
        make_folder(Path(out_dir) / "variants", kind="variant folder")
    case_file = d / f"{case_id}.parquet"
    write_files(dict(files or {}) | {case_file: lambda tmp: pq.write_table(table, tmp)},
                kind={case_file: "case file"} | {p: "variant file" for p in files or {}})


def read_case(path: Path, rows: set[int] | None = None, columns=CASE_COLUMNS):
    """A case file, checked: readable Parquet with the store's `columns` (a study's: CASE_COLUMNS), only its own case id
    (the file's name) and, when `rows` is given, a row count in it. Returns the pyarrow Table; raises
    ValueError saying what is wrong."""
    try:
        table = pq.read_table(path)
    except (OSError, ValueError, pa.ArrowException):
        raise ValueError("unreadable (truncated or not a Parquet file)") from None
    missing = [c for c in columns if c not in table.column_names]
    if missing:
        raise ValueError(f"no column {', '.join(missing)}")
    ids = set(table.column("case_id").to_pylist())
    if ids != {path.stem}:
        raise ValueError(f"holds case {', '.join(map(str, sorted(ids, key=str))) or 'nothing'}, expected {path.stem}")
    if rows is not None and table.num_rows not in rows:
        raise ValueError(f"{table.num_rows} rows, expected {' or '.join(map(str, sorted(rows)))}")
    return table


def expected_rows(case: dict, spec) -> set[int]:
    """Row counts a finished case's file may have: one for a start or a failed case, one per point for a
    Pareto chain."""
    return {1, spec.pareto.points} if case["kind"] == "pareto" else {1}


def done_cases(out_dir: Path, cases: list[dict] | None = None, spec=None, notice=None, columns=CASE_COLUMNS,
               rows=None) -> set[str]:
    """The ids of the cases whose files are in the store and pass `read_case` (with `cases` and `spec`:
    only the study's cases, with their row counts; `rows(case)`: another command's counts, with its
    `columns`), except those that ended in a RUN_FAILURES status. A corrupt file is said in one line by
    `notice` and left out, so its case runs again."""
    d = Path(out_dir) / "cases"
    if not d.is_dir():
        return set()
    files = {p.stem: p for p in d.glob("[!.]*.parquet")}
    wanted = files if cases is None else {c["id"]: c for c in cases if c["id"] in files}
    done = set()
    for cid in wanted:
        try:
            counts = None if cases is None else (rows or (lambda c: expected_rows(c, spec)))(wanted[cid])
            table = read_case(files[cid], counts, columns)
        except ValueError as e:
            if notice:
                notice(f"case file {files[cid]}: {e}; running the case again")
            continue
        if not any(str(s).startswith(RUN_FAILURES) for s in table.column("status").to_pylist()):
            done.add(cid)
    return done


def read_store(out_dir, columns=CASE_COLUMNS) -> pd.DataFrame:
    """Every case file of the store that passes `read_case` (with these `columns`), as one DataFrame (empty
    if none)."""
    tables = []
    for f in sorted((Path(out_dir) / "cases").glob("[!.]*.parquet")):
        with contextlib.suppress(ValueError):
            tables.append(read_case(f, columns=columns).to_pandas())
    return pd.concat(tables, ignore_index=True) if tables else pd.DataFrame()


def manifest(study_file, spec, digest: str) -> dict:
    versions = {p: metadata.version(p) for p in ("cvtdesign", "casadi", "numpy", "scipy", "dask", "distributed",
                                                 "pyarrow", "pandas")}
    return {"study": spec.name, "study_file": str(study_file), "study_hash": digest, "versions": versions,
            "solver": {"name": "ipopt", "max_iter": spec.max_iter} | IPOPT_OPTIONS}


def prepare_store(study_file, spec, digest: str, out_dir: Path, man: dict | None = None, option: str = "--out") -> dict:
    """Create or reopen the store; refuse one that belongs to another version of the study (`digest`, its
    study_hash; `option` names the command's option for another folder). `man`: the manifest to write
    (default: a study's, `manifest`), with the study_hash `digest`."""
    mpath = out_dir / "manifest.json"
    if mpath.exists():
        try:
            old = json.loads(mpath.read_text())
        except (OSError, ValueError) as e:
            raise InputError(f"{mpath}: cannot read the store's manifest ({e}); expected the JSON this command "
                             "writes (use --out for a new folder)") from None
        old = old if isinstance(old, dict) else {}
        if old.get("study_hash") != digest:
            raise InputError(f"{study_file}: the results folder {out_dir} holds another version of this study "
                             f"(hash {old.get('study_hash')} ≠ {digest}); use {option} for a new folder")
    man = man or manifest(study_file, spec, digest)
    write_file(mpath, json.dumps(man, indent=2) + "\n", kind="store manifest")
    return man


@contextlib.contextmanager
def store_lock(out_dir: Path):
    """Hold the store's lock (`<store>/.lock`, an OS file lock by filelock, released when the process ends
    however it ends) for the block; refuse at once, in one line, when another run holds it."""
    path = make_folder(out_dir, kind="results store") / ".lock"
    lock = FileLock(path, timeout=0)
    try:
        lock.acquire()
    except Timeout:
        raise InputError(f"{out_dir}: another run of the study holds this results store (lock {path}); wait for "
                         "it to finish or use --out for another folder") from None
    except OSError as e:
        raise OutputError(f"results store {out_dir}: cannot take its lock {path}: {e.strerror or e}") from None
    try:
        yield
    finally:
        lock.release()


