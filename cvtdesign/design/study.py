"""Batch studies on Dask: many optimisation cases at once, each written to the results store as it finishes.

Cases (design.cases): every base variant × sweep point × multistart point, plus Pareto chains (a chain is
sequential: each point warm-starts the next).

The store (design.store): one Parquet file per finished case, the designs as variant files and a
manifest; re-running the same command skips the cases already there.

What travels: the study's content, never a path (`StudyContent`, read and checked in design.cases and
sent once to each worker): the study spec, and each variant file's text and contents with the calibration
merged in (study_file.StudyVariant). A worker reads no input file and writes nothing; it returns the case's rows and
its optimum's variant files as text. So a study runs unchanged on workers that share neither this working
directory nor this filesystem; they need only the same version of cvtdesign (checked when they start).

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
once at start-up (`WarmWorkers`, a worker plugin: workers that join later are warmed too) and keeps the
problems it has built (a case's NLP depends only on its variant and sweep point, not on its start), and
the cases that share a problem are sent to the same worker (a preference: idle workers still take over),
the longest first.
"""
from __future__ import annotations

import json
import time
from concurrent.futures import CancelledError
from importlib import metadata
from pathlib import Path

import casadi as ca
import numpy as np
from dask.distributed import WorkerPlugin, as_completed
from distributed.scheduler import KilledWorker

from cvtdesign.design import cluster
from cvtdesign.design.cases import StudyContent, check_study, make_cases, study_content
from cvtdesign.design.problem import build_problem
from cvtdesign.design.infeasibility import unmet_constraints
from cvtdesign.design.report import variant_text
from cvtdesign.design.objectives import objective
from cvtdesign.design.solve import pareto_front, solve_from, starts
from cvtdesign.design.store import (
    done_cases,
    failure_rows,
    prepare_store,
    read_store,
    store_lock,
    write_case,
)
from cvtdesign.design.study_file import Study, StudyVariant
from cvtdesign.errors import InputError, RunError
from cvtdesign.io.output import remove_stale_temps
from cvtdesign.io.units import registry

class Interrupted(KeyboardInterrupt):
    """Ctrl-C during a study: the message says how many cases are kept in the store."""


_PROBLEMS: dict = {}     # worker-local: built problems by (study, variant, sweep point), most recent last
_KEEP = 4


def warm_worker() -> str:
    """Start-up of a worker: load what every case needs, so no case pays for it. Running this in a worker
    imports this module, and with it CasADi, the model, SciPy's Latin hypercube and the Parquet writer;
    here, the unit registry and CasADi's IPOPT and Newton plugins. Returns the worker's cvtdesign version."""
    registry()
    x = ca.SX.sym("x")
    ca.nlpsol("warm", "ipopt", {"x": x, "f": x * x}, {"ipopt": {"print_level": 0, "sb": "yes"}, "print_time": False})
    ca.rootfinder("warm", "newton", ca.Function("r", [x, ca.SX.sym("p")], [x]))
    return metadata.version("cvtdesign")


class WarmWorkers(WorkerPlugin):
    """`warm_worker` on every worker of the cluster, now and on each one that joins later (an adaptive
    dask-jobqueue or Kubernetes cluster grows while a study runs); a worker whose cvtdesign is not
    `version` (this process's) refuses it, since its cases would not be this version's."""
    name = "cvtdesign-warm"

    def __init__(self, version: str):
        self.version = version

    def setup(self, worker):
        found = warm_worker()
        if found != self.version:
            raise RuntimeError(f"worker {worker.address} runs cvtdesign {found}, the client {self.version}")


def cached_problem(content: StudyContent, variant: StudyVariant, fixed: dict):
    """The case's NLP, built once per worker: every start of a variant × sweep point shares it (keyed by
    the study's hash, which covers the contents of its files: an edited file is a new problem)."""
    key = (content.digest, variant.path, json.dumps(fixed, sort_keys=True))
    if key not in _PROBLEMS:
        _PROBLEMS[key] = build_problem(Study(content.path, content.spec, variant), fixed)
        while len(_PROBLEMS) > _KEEP:
            _PROBLEMS.pop(next(iter(_PROBLEMS)))
    else:
        _PROBLEMS[key] = _PROBLEMS.pop(key)
    return _PROBLEMS[key]


def run_case(content: StudyContent, case: dict, out_dir: str) -> dict:
    """Run one case in a worker, from `content` alone (no file is read or written here). Returns {"rows":
    one per optimum or Pareto point, "files": {path: text} of the optimum's variant files, named in the
    store `out_dir` of the client, which writes them}."""
    t0 = time.perf_counter()
    spec, variant = content.spec, content.variants[case["variant"]]
    common = {"case_id": case["id"], "kind": case["kind"], "variant": variant.name,
              "fixed": json.dumps(case["fixed"]), "start": case["start"]}
    vdir = Path(out_dir) / "variants"
    rows, files = [], {}

    def design_file(problem, sol, name: str) -> str | None:
        if not sol.success:
            return None
        path, files[path] = variant_text(problem, sol, vdir, name, study=True)
        return str(path)

    goal = objective(spec.objective.kind)
    if case["kind"] == "start":
        problem = cached_problem(content, variant, case["fixed"])
        sol = solve_from(problem, starts(problem)[case["start"]], case["start"])
        ok = sol.success
        rows.append(common | {"point": 0, "status": sol.status, "success": ok, "objective": _held(ok, sol.objective),
                              "worst_alpha_deg": _held(ok, sol.check.max_abs_alpha_deg if sol.check else np.nan),
                              "power_loss_W": _held(ok, goal.power_loss(sol.objective)),
                              "iterations": sol.iterations, "reason": failure_reason(problem, sol),
                              "variant_file": design_file(problem, sol, f"{spec.name}_{case['id']}")}
                    | {f"design.{k}": v for k, v in sol.design.items()})
    else:
        for p in pareto_front(Study(content.path, spec, variant), case["fixed"]):
            sol = p["solution"]
            ok = p["success"]
            rows.append(common | {"point": p["index"], "status": p["status"], "success": ok,
                                  "objective": _held(ok, p["power_loss_W"]),
                                  "worst_alpha_deg": _held(ok, p["worst_alpha_deg"]),
                                  "power_loss_W": _held(ok, p["power_loss_W"]), "iterations": sol.iterations,
                                  "reason": failure_reason(p["problem"], sol),
                                  "variant_file": design_file(p["problem"], sol, f"{spec.name}_{case['id']}{p['index']}")}
                        | {f"design.{k}": v for k, v in p["design"].items()})
    for r in rows:
        r["seconds"] = time.perf_counter() - t0
    return {"rows": rows, "files": files}


def failure_reason(problem, sol) -> str:
    """Why a case failed, for the store's `reason` column: the envelope check's worst point, or the constraint
    that no design within the bounds meets (design.infeasibility), or '' (a success, or no such constraint)."""
    if sol.success:
        return ""
    if sol.check is not None:
        return f"{sol.status}: worst point {sol.check.as_dict().get('worst')}"
    unmet = unmet_constraints(problem, starts(problem))
    return unmet[0]["text"] if unmet else ""


def _held(success: bool, value):
    """A case's figure, stored only where the physics held: a failed case's objective is the working set's,
    not the design's (NaN in the store)."""
    return value if success else np.nan


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


def run_study(study: Study, out_dir=None, scheduler: str | None = None, workers: int | None = None,
              progress=None, notice=None) -> dict:
    """Run every case not yet in the store on Dask; returns a summary dict. `progress(done, total, row)`
    follows the cases; `notice(text)` gets one-line notices (a corrupt case file run again). Bad input
    (the study, `workers`, a scheduler that does not answer, a store held by another run) is an
    InputError before any case runs; Ctrl-C raises `Interrupted` once the cluster is closed."""
    cluster.check_workers(workers, scheduler)
    study_file, spec = study.path, study.spec
    cases = make_cases(study)
    content = study_content(study, cases)
    check_study(content, cases)
    if scheduler:          # a scheduler that does not answer is refused before the results store is created
        cluster.connect(scheduler).close()
    out_dir = Path(out_dir or Path("results") / spec.name)
    with store_lock(out_dir):
        prepare_store(study_file, spec, content.digest, out_dir)
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
                startup, seconds = run_cases(content, todo, out_dir, (scheduler, workers), written, step)
            except KeyboardInterrupt:
                kept = len(done_cases(out_dir, cases, spec))      # what is in the store, counted from its files
                raise Interrupted(f"interrupted: {kept} of {len(cases)} cases finished and kept in {out_dir}; "
                                  "run again to resume") from None
        table = read_store(out_dir)
    return {"out_dir": str(out_dir), "cases": len(cases), "skipped": len(finished), "ran": len(todo),
            "seconds": seconds, "startup_seconds": startup, "table": table}


def run_cases(content, todo: list[dict], out_dir: Path, where: tuple, written: list, progress, task=run_case,
              failure=failure_rows, assign=None) -> tuple[float, float]:
    """Run `todo` on Dask (where: (scheduler, workers)), writing each case's file as it finishes and
    appending its id to `written`; returns (cluster start-up, cases) seconds. The content (a StudyContent,
    or another command's with a `digest`) is sent once to every worker (scattered), not with each case.
    `task(content, case, out_dir)` runs a case in a worker ({"rows", "files"}, as run_case), `failure(case,
    status)` gives the rows of a case that raised, `assign(todo, workers)` the (case, preferred worker,
    priority) of each (default: a study's `plan`)."""
    t_start = time.perf_counter()
    with cluster.dask_client(*where) as client:
        warm(client, where[0])
        client.wait_for_workers(1)     # a cluster that is still starting its workers (a batch queue)
        t0 = time.perf_counter()
        names = sorted(client.scheduler_info()["workers"])
        shared = client.scatter(content, broadcast=True, hash=False)
        futures = {client.submit(task, shared, c, str(out_dir), key=f"case-{content.digest}-{c['id']}",
                                 retries=0, pure=False, priority=prio,
                                 **({} if w is None else {"workers": [w], "allow_other_workers": True})): c
                   for c, w, prio in (assign(todo, names) if assign else plan(todo, names, content.spec.pareto.points))}
        lost = 0
        for fut in as_completed(futures):
            case = futures[fut]
            files = {}
            try:
                result = fut.result()
                rows, files = result["rows"], result["files"]
            except CancelledError:  # the scheduler (or the connection to it) is gone: the case did not run
                lost += 1
                continue
            except KilledWorker:
                rows = failure(case, "worker_crashed")
            except Exception as e:  # recorded in the store, never swallowed
                rows = failure(case, f"error: {type(e).__name__}: {e}")
            write_case(out_dir, case["id"], rows, files)
            written.append(case["id"])
            progress(rows[0])
        if lost:
            raise RunError(f"the cluster lost {lost} of {len(todo)} cases (its scheduler stopped or became "
                           f"unreachable); {len(written)} finished and are kept in {out_dir}; run again to resume")
        return t0 - t_start, time.perf_counter() - t0


def warm(client, scheduler: str | None) -> None:
    """Warm every worker of the client's cluster (WarmWorkers); a worker that cannot run this version's
    cases is one InputError line."""
    version = metadata.version("cvtdesign")
    try:
        client.register_plugin(WarmWorkers(version), name=WarmWorkers.name)
    except Exception as e:    # raised in a worker: a missing or different cvtdesign, a broken install
        where = f"--scheduler {scheduler}" if scheduler else "local cluster"
        raise InputError(f"{where}: a worker cannot run this study's cases ({type(e).__name__}: "
                         f"{' '.join(str(e).split())}); expected cvtdesign {version} installed on every "
                         "worker") from None
