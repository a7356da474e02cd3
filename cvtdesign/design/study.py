"""Batch studies on Dask: many optimisation cases at once, each written to the results store as it finishes.

Cases: every base variant (`batch.variants`, default the study's `base`) × every combination of the swept
fixed parameters (`batch.sweep`) × every multistart point (`multistart.starts`), plus, with
`batch.pareto`, one ε-constraint Pareto chain per variant × sweep combination (a chain is sequential:
each point warm-starts the next).

Store (`results/<study>/` by default): `cases/<case id>.parquet`, one file per finished case written
atomically (a Parquet dataset readable with pandas/pyarrow as a whole), `variants/` the designs as variant
files, and `manifest.json` (study hash, package versions, solver options). Re-running the same command
skips the cases already in the store, so a killed study loses nothing it had finished; a store made by a
different study file (another hash) is refused. Each case's status is recorded: IPOPT's status
(Solve_Succeeded, Infeasible_Problem_Detected, Maximum_Iterations_Exceeded, ...), `worker_crashed`, or
`error: ...`; nothing is swallowed. Every file goes through output.write_file (atomic, umask's mode).

A run:
 1. checks `--workers` and the whole study before anything is written or submitted: every variant file ×
    sweep point's inputs (study_file.problem_inputs: parameters, bounds, geometry, effects, envelope,
    constraints, solver options); a bad input is one InputError line, exit status 2;
 2. takes the store's lock (`<store>/.lock`, filelock): a second run on the same store is refused at once;
 3. reads and checks every case file (readable Parquet, the store's columns, its own case id, the case's
    row count); a corrupt one (e.g. truncated by a full disk) is said in one line and its case runs again;
 4. runs the rest (none: no cluster is started, the summary is the store's); Ctrl-C stops the cluster and
    raises `Interrupted` ("interrupted: N of M cases finished and kept in <store>; run again to resume").

Dask: by default a LocalCluster started by the command, one single-threaded worker process per core;
`--scheduler ADDRESS` sends the same cases to an existing cluster unchanged. Each worker imports the model
once at start-up and keeps the problems it has built (a case's NLP depends only on its variant and sweep
point, not on its start), and the cases that share a problem are sent to the same worker (a preference:
idle workers still take over), the long Pareto chains first.
"""
from __future__ import annotations

import contextlib
import hashlib
import itertools
import json
import os
import time
from importlib import metadata
from pathlib import Path

import casadi as ca
import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
from dask.distributed import as_completed
from distributed.scheduler import KilledWorker
from filelock import FileLock, Timeout

from cvtdesign.design import cluster
from cvtdesign.design.problem import IPOPT_OPTIONS, build_problem
from cvtdesign.design.report import write_variant
from cvtdesign.design.solve import pareto_front, solve_from, starts
from cvtdesign.design.study_file import load_study, problem_inputs
from cvtdesign.errors import InputError
from cvtdesign.io.output import OutputError, make_folder, remove_stale_temps, write_file
from cvtdesign.io.units import registry
from cvtdesign.io.variant import parameter_value

# the columns every case file has (besides design.<variable>)
CASE_COLUMNS = ("case_id", "kind", "variant", "fixed", "start", "point", "status", "success", "objective",
                "worst_alpha_deg", "power_loss_W", "iterations", "variant_file", "seconds")


class Interrupted(KeyboardInterrupt):
    """Ctrl-C during a study: the message says how many cases are kept in the store."""


def study_hash(study_file: Path, spec, base: Path) -> str:
    """Hash of the study file, of every variant file it names and of its calibration report (so an edited
    variant or a new fit is a new study)."""
    h = hashlib.sha256(Path(study_file).read_bytes())
    for v in variant_files(study_file, spec, base):
        h.update(v.read_bytes())
    if spec.calibration:
        h.update((Path(study_file).parent / spec.calibration).read_bytes())
    return h.hexdigest()[:16]


def variant_files(study_file, spec, base) -> list[Path]:
    if not spec.batch.variants:
        return [base]
    files = [Path(study_file).parent / v for v in spec.batch.variants]
    for v, f in zip(spec.batch.variants, files):
        if not f.exists():
            raise InputError(f"{study_file}: batch.variants: no variant file '{v}' next to the study")
    return files


def make_cases(study_file, spec=None, base: Path | None = None) -> list[dict]:
    """The study's cases, each a small picklable dict with a stable id (spec, base: the loaded study)."""
    if spec is None:
        spec, base = load_study(study_file)
    sweep = {k: [parameter_value(v, f"{study_file}: batch.sweep.{k}", {}) for v in vals] for k, vals in spec.batch.sweep.items()}
    combos = [dict(zip(sweep, vals)) for vals in itertools.product(*sweep.values())] or [{}]
    cases = []
    for vf in variant_files(study_file, spec, base):
        for fixed in combos:
            tag = "_".join(f"{k}={v:.6g}" for k, v in fixed.items())
            stem = vf.stem + (f"_{tag}" if tag else "")
            for k in range(max(spec.multistart.starts, 1)):
                cases.append({"id": f"{stem}_start{k}", "kind": "start", "variant": str(vf), "fixed": fixed, "start": k})
            if spec.batch.pareto:
                cases.append({"id": f"{stem}_pareto", "kind": "pareto", "variant": str(vf), "fixed": fixed, "start": 0})
    return cases


def check_study(study_file, spec, cases: list[dict]) -> None:
    """Every distinct problem's inputs (variant file × sweep point), checked before any case is submitted:
    one InputError line for the first bad one (see study_file.problem_inputs)."""
    seen = set()
    for c in cases:
        key = (c["variant"], json.dumps(c["fixed"], sort_keys=True))
        if key not in seen:
            seen.add(key)
            problem_inputs(study_file, spec, Path(c["variant"]), c["fixed"])


_PROBLEMS: dict = {}     # worker-local: built problems by (study, variant, sweep point), most recent last
_KEEP = 4


def warm_worker() -> int:
    """Start-up of a worker: load what every case needs, so no case pays for it. Running this in a worker
    imports this module, and with it CasADi, the model, SciPy's Latin hypercube and the Parquet writer;
    here, the unit registry and CasADi's IPOPT and Newton plugins."""
    registry()
    x = ca.SX.sym("x")
    ca.nlpsol("warm", "ipopt", {"x": x, "f": x * x}, {"ipopt": {"print_level": 0, "sb": "yes"}, "print_time": False})
    ca.rootfinder("warm", "newton", ca.Function("r", [x, ca.SX.sym("p")], [x]))
    return os.getpid()


def cached_problem(study_file: str, spec, base: Path, fixed: dict):
    """The case's NLP, built once per worker: every start of a variant × sweep point shares it (keyed by
    the study's and variant's contents, so an edited file is a new problem)."""
    key = (str(study_file), hashlib.sha256(Path(study_file).read_bytes() + base.read_bytes()).hexdigest(),
           str(base), json.dumps(fixed, sort_keys=True))
    if key not in _PROBLEMS:
        _PROBLEMS[key] = build_problem(study_file, spec, base, fixed)
        while len(_PROBLEMS) > _KEEP:
            _PROBLEMS.pop(next(iter(_PROBLEMS)))
    else:
        _PROBLEMS[key] = _PROBLEMS.pop(key)
    return _PROBLEMS[key]


def run_case(study_file: str, case: dict, out_dir: str) -> list[dict]:
    """Run one case in a worker; returns its rows (one per optimum or Pareto point)."""
    t0 = time.perf_counter()
    spec, _ = load_study(study_file)
    base = Path(case["variant"])
    common = {"case_id": case["id"], "kind": case["kind"], "variant": base.name,
              "fixed": json.dumps(case["fixed"]), "start": case["start"]}
    vdir = Path(out_dir) / "variants"
    rows = []
    if case["kind"] == "start":
        problem = cached_problem(study_file, spec, base, case["fixed"])
        sol = solve_from(problem, starts(problem)[case["start"]], case["start"])
        vfile = str(write_variant(problem, sol, vdir, f"{spec.name}_{case['id']}")) if sol.success else None
        rows.append(common | {"point": 0, "status": sol.status, "success": sol.success, "objective": sol.objective,
                              "worst_alpha_deg": sol.check.max_abs_alpha_deg if sol.check else np.nan,
                              "power_loss_W": sol.objective if spec.objective.kind == "power_loss" else np.nan,
                              "iterations": sol.iterations,
                              "variant_file": vfile} | {f"design.{k}": v for k, v in sol.design.items()})
    else:
        for p in pareto_front(study_file, spec, base, case["fixed"]):
            sol, problem = p["solution"], p["problem"]
            name = f"{spec.name}_{case['id']}{p['index']}"
            vfile = str(write_variant(problem, sol, vdir, name)) if sol.success else None
            rows.append(common | {"point": p["index"], "status": p["status"], "success": p["success"],
                                  "objective": p["power_loss_W"], "worst_alpha_deg": p["worst_alpha_deg"],
                                  "power_loss_W": p["power_loss_W"], "iterations": sol.iterations,
                                  "variant_file": vfile} | {f"design.{k}": v for k, v in p["design"].items()})
    for r in rows:
        r["seconds"] = time.perf_counter() - t0
    return rows


def plan(cases: list[dict], workers: list[str], pareto_points: int = 8) -> list[tuple[dict, str | None, int]]:
    """(case, preferred worker, priority) for each case. Cases that share a problem (same variant and sweep
    point) form a group that goes to one worker, so the problem is built once; groups are split while
    there are fewer of them than workers, then dealt longest first to the least loaded worker. A Pareto
    chain (about points + 2 solves) runs before the single starts."""
    cost = {"start": 1.0, "pareto": pareto_points + 2.0}
    build = 3.0                                    # building a problem, in single solves
    groups: dict = {}
    for c in cases:
        groups.setdefault((c["variant"], json.dumps(c["fixed"], sort_keys=True)), []).append(c)
    units = sorted(groups.values(), key=lambda g: -sum(cost[c["kind"]] for c in g))
    while workers and units and len(units) < len(workers) and len(units[0]) > 1:
        big = units.pop(0)
        units += [big[: len(big) // 2], big[len(big) // 2:]]
        units.sort(key=lambda g: -sum(cost[c["kind"]] for c in g))
    load = {w: 0.0 for w in workers}
    out = []
    for unit in units:
        w = min(load, key=load.get) if workers else None
        if w is not None:
            load[w] += build + sum(cost[c["kind"]] for c in unit)
        out += [(c, w, int(cost[c["kind"]])) for c in unit]
    return out


def failure_rows(case: dict, status: str) -> list[dict]:
    return [{"case_id": case["id"], "kind": case["kind"], "variant": Path(case["variant"]).name,
             "fixed": json.dumps(case["fixed"]), "start": case["start"], "point": 0, "status": status,
             "success": False, "objective": np.nan, "worst_alpha_deg": np.nan, "power_loss_W": np.nan,
             "iterations": 0, "variant_file": None, "seconds": np.nan}]


def write_case(out_dir: Path, case_id: str, rows: list[dict]):
    """One Parquet file per case, by output.write_file (pyarrow writes the temporary file, which is then
    renamed: never half-written); pyarrow directly, a third of pandas' time, which matters in the client
    that also runs the scheduler."""
    table = pa.Table.from_pylist(rows)
    d = make_folder(Path(out_dir) / "cases", kind="results store")
    write_file(d / f"{case_id}.parquet", lambda tmp: pq.write_table(table, tmp), kind="case file")


def read_case(path: Path, rows: set[int] | None = None):
    """A case file, checked: readable Parquet with the store's columns (CASE_COLUMNS), only its own case id
    (the file's name) and, when `rows` is given, a row count in it. Returns the pyarrow Table; raises
    ValueError saying what is wrong."""
    try:
        table = pq.read_table(path)
    except (OSError, ValueError, pa.ArrowException):
        raise ValueError("unreadable (truncated or not a Parquet file)") from None
    missing = [c for c in CASE_COLUMNS if c not in table.column_names]
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


def done_cases(out_dir: Path, cases: list[dict] | None = None, spec=None, notice=None) -> set[str]:
    """The ids of the cases whose files are in the store and pass `read_case` (with `cases` and `spec`:
    only the study's cases, with their row counts). A corrupt file is said in one line by `notice` and left
    out, so its case runs again."""
    d = Path(out_dir) / "cases"
    if not d.is_dir():
        return set()
    files = {p.stem: p for p in d.glob("[!.]*.parquet")}
    wanted = files if cases is None else {c["id"]: c for c in cases if c["id"] in files}
    done = set()
    for cid in wanted:
        try:
            read_case(files[cid], None if cases is None else expected_rows(wanted[cid], spec))
            done.add(cid)
        except ValueError as e:
            if notice:
                notice(f"case file {files[cid]}: {e}; running the case again")
    return done


def read_store(out_dir) -> pd.DataFrame:
    """Every case file of the store that passes `read_case`, as one DataFrame (empty if none)."""
    tables = []
    for f in sorted((Path(out_dir) / "cases").glob("[!.]*.parquet")):
        with contextlib.suppress(ValueError):
            tables.append(read_case(f).to_pandas())
    return pd.concat(tables, ignore_index=True) if tables else pd.DataFrame()


def manifest(study_file, spec, digest: str) -> dict:
    versions = {p: metadata.version(p) for p in ("cvtdesign", "casadi", "numpy", "scipy", "dask", "distributed",
                                                 "pyarrow", "pandas")}
    return {"study": spec.name, "study_file": str(study_file), "study_hash": digest, "versions": versions,
            "solver": {"name": "ipopt", "max_iter": spec.max_iter} | IPOPT_OPTIONS}


def prepare_store(study_file, spec, base: Path, out_dir: Path) -> dict:
    """Create or reopen the store; refuse one that belongs to another version of the study."""
    digest = study_hash(study_file, spec, base)
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
                             f"(hash {old.get('study_hash')} ≠ {digest}); use --out for a new folder")
    man = manifest(study_file, spec, digest)
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


def run_study(study_file, out_dir=None, scheduler: str | None = None, workers: int | None = None,
              progress=None, notice=None) -> dict:
    """Run every case not yet in the store on Dask; returns a summary dict. `progress(done, total, row)`
    follows the cases; `notice(text)` gets one-line notices (a corrupt case file run again). Bad input
    (the study, `workers`, a scheduler that does not answer, a store held by another run) is an
    InputError before any case runs; Ctrl-C raises `Interrupted` once the cluster is closed."""
    cluster.check_workers(workers)
    spec, base = load_study(study_file)
    cases = make_cases(study_file, spec, base)
    check_study(study_file, spec, cases)
    if scheduler:          # a scheduler that does not answer is refused before the results store is created
        cluster.connect(scheduler).close()
    out_dir = Path(out_dir or Path("results") / spec.name)
    with store_lock(out_dir):
        man = prepare_store(study_file, spec, base, out_dir)
        for folder in (out_dir, out_dir / "cases", out_dir / "variants"):
            if folder.is_dir():
                remove_stale_temps(folder)       # left by a killed run; nobody else writes here now
        finished = done_cases(out_dir, cases, spec, notice)
        todo = [c for c in cases if c["id"] not in finished]
        if progress:
            progress(len(finished), len(cases), None)
        written: list[str] = []
        startup = seconds = 0.0

        def step(row):
            if progress:
                progress(len(finished) + len(written), len(cases), row)

        if todo:
            try:
                startup, seconds = _run_cases(study_file, spec, man, todo, out_dir, (scheduler, workers), written,
                                              step)
            except KeyboardInterrupt:
                kept = len(done_cases(out_dir, cases, spec))      # what is in the store, counted from its files
                raise Interrupted(f"interrupted: {kept} of {len(cases)} cases finished and kept in {out_dir}; "
                                  "run again to resume") from None
        table = read_store(out_dir)
    return {"out_dir": str(out_dir), "cases": len(cases), "skipped": len(finished), "ran": len(todo),
            "seconds": seconds, "startup_seconds": startup, "table": table}


def _run_cases(study_file, spec, man: dict, todo: list[dict], out_dir: Path, where: tuple, written: list,
               progress) -> tuple[float, float]:
    """Run `todo` on Dask (where: (scheduler, workers)), writing each case's file as it finishes and
    appending its id to `written`; returns (cluster start-up, cases) seconds."""
    t_start = time.perf_counter()
    with cluster.dask_client(*where) as client:
        client.run(warm_worker)
        t0 = time.perf_counter()
        names = sorted(client.scheduler_info()["workers"])
        futures = {client.submit(run_case, str(study_file), c, str(out_dir), key=f"case-{man['study_hash']}-{c['id']}",
                                 retries=0, pure=False, priority=prio,
                                 **({} if w is None else {"workers": [w], "allow_other_workers": True})): c
                   for c, w, prio in plan(todo, names, spec.pareto.points)}
        for fut in as_completed(futures):
            case = futures[fut]
            try:
                rows = fut.result()
            except KilledWorker:
                rows = failure_rows(case, "worker_crashed")
            except Exception as e:  # recorded in the store, never swallowed
                rows = failure_rows(case, f"error: {type(e).__name__}: {e}")
            write_case(out_dir, case["id"], rows)
            written.append(case["id"])
            progress(rows[0])
        return t0 - t_start, time.perf_counter() - t0
