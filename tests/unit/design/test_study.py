"""Batch studies on a real Dask cluster: the store, resume after an interruption, a finished or corrupt store,
the store's lock, Ctrl-C, bad settings and bad studies refused before any case runs, recorded statuses.

Most runs share one LocalCluster (module fixture, passed as --scheduler: a cluster start costs ~1.5 s);
the interrupted run starts its own, so that the Ctrl-C path closes a cluster of its own."""
import contextlib
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path
from types import SimpleNamespace

import dask
import numpy as np
import pandas as pd
import pytest
import yaml
from dask.distributed import Client
from filelock import FileLock

from conftest import ROOT

from cvtdesign.design import cluster
from cvtdesign.design import store as store_mod
from cvtdesign.design import study as study_mod
from cvtdesign.cli import main
from cvtdesign.design.store import read_store
from cvtdesign.design.cases import make_cases
from cvtdesign.design.study import run_study
from cvtdesign.core.model import compile_model
from cvtdesign.design.study_file import load_study
from cvtdesign.errors import InputError
from cvtdesign.io.variant import load_variant

CONNECT = cluster.connect


def small_study(folder, name="small.yaml", **extra):
    data = {"name": "small", "base": str(ROOT / "variants/box_kim.yaml"),
            "design": {"d": {"lower": "30 mm", "upper": "110 mm"}},
            "constraints": {"clearance": "2 mm"},
            "envelope": {"gamma": {"start": "-60 deg", "stop": "60 deg", "step": "60 deg"},
                         "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "2 N*m"}},
            "multistart": {"starts": 3, "seed": 2},
            "batch": {"sweep": {"r_steer": ["30 mm", "38 mm"]}}}
    data.update(extra)
    path = Path(folder) / name
    path.write_text(yaml.safe_dump(data, allow_unicode=True))
    return path


def comparable(df):
    cols = ["case_id", "point", "status", "success", "objective", "design.d"]
    return df[cols].sort_values(["case_id", "point"]).reset_index(drop=True)


def case_files(store) -> list[Path]:
    return sorted((Path(store) / "cases").glob("[!.]*.parquet"))


def one_line(err: str, *needles):
    assert err.count("\n") == 1 and "Traceback" not in err, err
    for n in needles:
        assert n in err, err


@pytest.fixture(scope="module")
def shared(tmp_path_factory):
    """A LocalCluster of 2 workers for the runs that need no cluster of their own."""
    c = cluster.local_cluster(2)
    yield c.scheduler_address
    c.close()


@pytest.fixture(scope="module")
def finished(tmp_path_factory, shared):
    """(study file, a finished store of its 6 cases, the store's table)."""
    folder = tmp_path_factory.mktemp("finished")
    path = small_study(folder)
    res = run_study(load_study(path), folder / "store", scheduler=shared)
    assert res["ran"] == 6 and res["table"]["success"].all()
    return path, folder / "store", res["table"]


@pytest.fixture
def no_cluster(monkeypatch):
    """Fail the test if a cluster were started or reached (nothing may be submitted)."""
    def refuse(*args, **kwargs):
        raise AssertionError("a cluster was started")
    monkeypatch.setattr(cluster, "local_cluster", refuse)
    monkeypatch.setattr(cluster, "connect", refuse)


def copy_store(store, tmp_path) -> Path:
    return Path(shutil.copytree(store, tmp_path / "store"))


def test_cases_are_the_product(tmp_path):
    cases = make_cases(load_study(small_study(tmp_path)))
    assert len(cases) == 6 and len({c["id"] for c in cases}) == 6
    assert {c["fixed"]["r_steer"] for c in cases} == {0.030, 0.038}
    # ids name the optimum variant files, which the tool must read back (an '=' in them was refused)
    assert all(re.fullmatch(r"[A-Za-z0-9_.+-]+", c["id"]) for c in cases), [c["id"] for c in cases]


@pytest.mark.slow
def test_finished_store_holds_the_closed_form_optimum(finished):
    _, store, table = finished
    assert len(case_files(store)) == 6 and (store / "manifest.json").exists()
    # the optimum: the closed form of test_optimise for each steering radius
    for rs, d in zip((0.030, 0.038), sorted(table.groupby("fixed")["design.d"].mean())):
        assert d == pytest.approx(0.0635 * (2 * rs + 0.002) / (0.0635 + rs), rel=1e-4)


@pytest.mark.slow
def test_interrupt_then_resume(tmp_path, finished, shared, capfd, monkeypatch):
    """Ctrl-C (a KeyboardInterrupt once the second case is stored) closes the run's own LocalCluster and says
    in one line what is kept; the next run resumes from there and reaches the uninterrupted result."""
    path, _, ref = finished
    out = tmp_path / "s"
    real = study_mod.write_case

    def write_then_interrupt(out_dir, case_id, rows, files=None):
        real(out_dir, case_id, rows, files)
        if len(case_files(out_dir)) == 2:
            raise KeyboardInterrupt
    monkeypatch.setattr(study_mod, "write_case", write_then_interrupt)
    assert main(["study", str(path), "--out", str(out), "--workers", "2"]) == 130
    err = capfd.readouterr().err                    # file descriptor 2: worker processes and logging included
    one_line(err, f"cvtdesign: interrupted: 2 of 6 cases finished and kept in {out}; run again to resume")
    assert len(case_files(out)) == 2
    monkeypatch.setattr(study_mod, "write_case", real)
    # what a killed run leaves: a half-written temporary file (removed under the lock)
    stale = out / "cases" / ".x.parquet.0123abcd.tmp.parquet"
    stale.write_bytes(b"PAR1")
    res = run_study(load_study(path), out, scheduler=shared)
    assert res["skipped"] == 2 and res["ran"] == 4 and not stale.exists()
    pd.testing.assert_frame_equal(comparable(res["table"]), comparable(ref), rtol=1e-9)


def test_rerun_when_finished_prints_summary_and_recomputes_nothing(tmp_path, finished, capsys, no_cluster):
    """A completed store run again (no cluster may start): nothing runs, no case file is rewritten, exit 0,
    and the table is the first run's."""
    path, store, ref = finished
    store = copy_store(store, tmp_path)
    before = {f: f.stat().st_mtime_ns for f in case_files(store)}
    assert main(["study", str(path), "--out", str(store), "--workers", "2"]) == 0
    out = capsys.readouterr().out
    assert f"6 cases: all already in {store}; nothing to run" in out and "Solve_Succeeded" in out
    assert {f: f.stat().st_mtime_ns for f in case_files(store)} == before
    res = run_study(load_study(path), store)
    assert (res["skipped"], res["ran"]) == (6, 0)
    pd.testing.assert_frame_equal(comparable(res["table"]), comparable(ref), rtol=0, atol=0)


def test_corrupt_case_file_is_run_again(tmp_path, finished, shared):
    path, store, ref = finished
    store = copy_store(store, tmp_path)
    bad = case_files(store)[0]
    os.truncate(bad, bad.stat().st_size // 2)
    notices = []
    res = run_study(load_study(path), store, scheduler=shared, notice=notices.append)
    assert notices == [f"case file {bad}: unreadable (truncated or not a Parquet file); running the case again"]
    assert res["skipped"] == 5 and res["ran"] == 1
    pd.testing.assert_frame_equal(comparable(res["table"]), comparable(ref), rtol=1e-9)


def test_second_concurrent_run_is_refused(tmp_path, finished, capsys, no_cluster):
    path, store, _ = finished
    store = copy_store(store, tmp_path)
    for f in case_files(store):
        f.unlink()
    with FileLock(store / ".lock"):     # the store's lock is taken with timeout 0: refused, not waited for
        assert main(["study", str(path), "--out", str(store)]) == 2
    one_line(capsys.readouterr().err, f"cvtdesign: error: {store}: another run of the study holds this results store")
    assert case_files(store) == []


@pytest.mark.parametrize("workers", ["-1", "0"])
def test_bad_workers_refused(tmp_path, capsys, no_cluster, workers):
    assert main(["study", str(small_study(tmp_path)), "--out", str(tmp_path / "s"), "--workers", workers]) == 2
    one_line(capsys.readouterr().err, f"--workers: expected a positive number of worker processes, got {workers}")
    assert not (tmp_path / "s").exists()


def test_more_workers_than_cores_refused_at_once_leaving_nothing(tmp_path, capsys, no_cluster):
    """`study --workers 100000` on a 2-core machine gave no refusal, was still starting workers after 150 s
    and left res/.lock and res/manifest.json: now one line that gives the limit, in under 5 s, with nothing
    written and no progress bar before it."""
    out, cores = tmp_path / "res", len(os.sched_getaffinity(0))
    t0 = time.perf_counter()
    assert main(["study", str(small_study(tmp_path)), "--out", str(out), "--workers", "100000"]) == 2
    assert time.perf_counter() - t0 < 5
    cap = capsys.readouterr()
    one_line(cap.err, f"--workers: 100000 worker processes on the {cores} cores this process may use; expected at "
                      f"most {cores}")
    assert cap.out == "" and not out.exists()


def test_a_refused_study_prints_no_progress_bar(tmp_path, capsys, no_cluster):
    """Every study refusal printed an empty progress bar ('cases ━━━━ 0/? 0:00:00') before its one line."""
    bad = small_study(tmp_path, multistart={"starts": 0})
    assert main(["study", str(bad), "--out", str(tmp_path / "s")]) == 2
    cap = capsys.readouterr()
    one_line(cap.err, "multistart.starts")
    assert cap.out == ""


@pytest.mark.slow
def test_sigterm_stops_a_study_as_ctrl_c_does(tmp_path):
    """SIGTERM (`kill`, a batch system's stop) ended a study with no message. Now it closes the cluster and
    says in the same one line as Ctrl-C how many cases are kept, which stay in the store (exit 128 + 15)."""
    path, out = small_study(tmp_path), tmp_path / "s"
    script = Path(sys.executable).parent / "cvtdesign"
    proc = subprocess.Popen([str(script), "study", str(path), "--out", str(out), "--workers", "1"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 180
    while not case_files(out) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.1)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    kept = len(case_files(out))
    assert proc.returncode == 143 and 1 <= kept < 6, (proc.returncode, err)
    one_line(err, f"cvtdesign: interrupted: {kept} of 6 cases finished and kept in {out}; run again to resume")


def test_unreachable_scheduler_refused_within_the_timeout(tmp_path, capsys, monkeypatch):
    with socket.socket() as s:                  # a port with nothing listening
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT", 1.0)     # the message says which timeout was used
    assert main(["study", str(small_study(tmp_path)), "--out", str(tmp_path / "s"),
                 "--scheduler", f"tcp://127.0.0.1:{port}"]) == 2
    one_line(capsys.readouterr().err, f"--scheduler tcp://127.0.0.1:{port}: no Dask scheduler answered within 1 s")
    assert case_files(tmp_path / "s") == []


@pytest.mark.parametrize("reply, message", [
    (None, "no Dask scheduler answered within 1 s"),            # it accepts and says nothing: a Client waited forever
    (b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n",  # a web server: a 47-line traceback (3 EiB)
     "what answers there is not a Dask scheduler"),
])
def test_a_port_that_is_not_a_dask_scheduler_is_refused(tmp_path, capsys, monkeypatch, no_cluster, reply, message):
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(4)
    port, held = server.getsockname()[1], []

    def serve():
        with contextlib.suppress(OSError):
            while True:
                conn, _ = server.accept()
                held.append(conn)
                if reply:
                    conn.sendall(reply)
    threading.Thread(target=serve, daemon=True).start()
    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT", 1.0)
    monkeypatch.setattr(cluster, "connect", CONNECT)     # the real one (no_cluster refuses it)
    try:
        assert main(["study", str(small_study(tmp_path)), "--out", str(tmp_path / "s"),
                     "--scheduler", f"tcp://127.0.0.1:{port}"]) == 2
    finally:
        server.close()
        for c in held:
            c.close()
    one_line(capsys.readouterr().err, f"--scheduler tcp://127.0.0.1:{port}: {message}")
    assert not (tmp_path / "s").exists()


@pytest.mark.parametrize("fields, message", [
    ({"design": {"d": {"lower": "110 mm", "upper": "30 mm"}}}, "design.d: inverted bounds"),
    ({"batch": {"sweep": {"r_stear": ["30 mm"]}}}, "batch.sweep.r_stear: the variant box_kim.yaml has no parameter"),
    ({"batch": {"variants": ["box_kim.yaml", "nope.yaml"]}}, "batch.variants: no variant file 'nope.yaml'"),
    ({"batch": {"variants": ["box_kim.yaml", "broken.yaml"]}}, "broken.yaml: sphere: missing required field"),
    ({"max_iter": 0}, "max_iter: expected an integer from 1 to 10000, got 0"),
    ({"effects": ["drive_longitudinal_creep", "bogus_creep"]}, "effects: unknown effect 'bogus_creep'"),
    ({"constraints": {"min_normal_force": "-5 N"}}, "constraints.min_normal_force: expected a positive force"),
    # two files of one name shared their case ids and result files: one design silently replaced the other
    ({"batch": {"variants": ["box_kim.yaml", "alt/box_kim.yaml"]}},
     "batch.variants: 'box_kim.yaml' and 'alt/box_kim.yaml' have the same name 'box_kim'"),
    # counts are checked before the cases are built (3 million starts took 1.1 GB first)
    ({"multistart": {"starts": 3_000_000}}, "multistart.starts: expected an integer from 1 to 10000, got 3000000"),
    ({"batch": {"sweep": {"preload": [f"{50 + k} N" for k in range(1000)], "r_steer": ["30 mm"] * 10}}},
     "make 30000 cases; expected at most 10000"),
    ({"batch": {"sweep": {"preload": []}}}, "batch.sweep.preload: no values; expected at least one"),
    # a design variable free only in a file the study does not run stayed fixed without a word
    ({"design": {"d": {"lower": "30 mm", "upper": "110 mm", "variants": ["alt/box_kim.yaml"]}},
      "batch": {"variants": ["box_kim.yaml"]}}, "design.d.variants: 'alt/box_kim.yaml' is not one of batch.variants"),
])
def test_bad_study_refused_before_any_case(tmp_path, capsys, no_cluster, fields, message):
    shutil.copy(ROOT / "variants/box_kim.yaml", tmp_path / "box_kim.yaml")
    (tmp_path / "alt").mkdir()
    shutil.copy(ROOT / "variants/box_kim.yaml", tmp_path / "alt" / "box_kim.yaml")
    (tmp_path / "broken.yaml").write_text("name: broken\n")
    path = small_study(tmp_path, **fields)
    assert main(["study", str(path), "--out", str(tmp_path / "s")]) == 2
    one_line(capsys.readouterr().err, message)
    assert not (tmp_path / "s").exists()


def test_other_study_in_store_is_refused(tmp_path, finished, no_cluster):
    path, store, _ = finished
    store = copy_store(store, tmp_path)
    other = small_study(tmp_path, design={"d": {"lower": "30 mm", "upper": "100 mm"}})
    with pytest.raises(InputError, match="holds another version of this study"):
        run_study(load_study(other), store)


@pytest.mark.slow
def test_failed_case_status_is_recorded(tmp_path, shared, capsys):
    """An infeasible case (clearance impossible inside the bounds) is stored with IPOPT's status, and the
    command exits 1 (no case succeeded)."""
    study = small_study(tmp_path, constraints={"clearance": "80 mm"}, multistart={"starts": 1},
                        batch={"sweep": {}})
    assert main(["study", str(study), "--out", str(tmp_path / "f"), "--scheduler", shared]) == 1
    df = read_store(tmp_path / "f")
    assert df["status"].iloc[0] == "Infeasible_Problem_Detected"
    assert df["reason"].iloc[0].startswith("clearance: clearance ") and "for every design within the bounds" in df["reason"].iloc[0]
    assert "no case succeeded: all 1 cases failed: clearance: clearance " in " ".join(capsys.readouterr().out.split())
    assert len(df) == 1 and not df["success"].iloc[0]
    assert df["status"].iloc[0] in ("Infeasible_Problem_Detected", "Restoration_Failed", "Maximum_Iterations_Exceeded")
    assert df["variant_file"].iloc[0] is None
    # no figure where the physics failed (the working set's objective is not the design's)
    assert df[["objective", "worst_alpha_deg", "power_loss_W"]].isna().all(axis=None)


def test_case_that_ended_in_an_error_runs_again(tmp_path, finished, shared):
    """A case stored as `error: ...` or `worker_crashed` (what happened to the run, e.g. a worker that could
    not read a file) is not a result: the next run runs it again and reaches the finished store's table."""
    path, store, ref = finished
    store = copy_store(store, tmp_path)
    cases = make_cases(load_study(path))
    store_mod.write_case(store, cases[0]["id"], store_mod.failure_rows(cases[0], "error: OSError: gone"))
    store_mod.write_case(store, cases[1]["id"], store_mod.failure_rows(cases[1], "worker_crashed"))
    res = run_study(load_study(path), store, scheduler=shared)
    assert res["skipped"] == 4 and res["ran"] == 2
    pd.testing.assert_frame_equal(comparable(res["table"]), comparable(ref), rtol=1e-9)


def test_no_successful_case_reports_the_failures_and_nothing_else(tmp_path, capsys, monkeypatch):
    """When every case failed (here a Pareto chain and a start, as a worker that cannot read the study left
    them) the command says how many failed and why, prints no optimum, front or knee, draws no plot, and
    exits 1."""
    path = small_study(tmp_path, batch={"pareto": True})
    cases = make_cases(load_study(path))
    why = "error: InputError: studies/x.yaml: cannot read file (No such file or directory)"
    rows = [r for c in cases[-2:] for r in store_mod.failure_rows(c, why)]
    monkeypatch.setattr(study_mod, "run_study", lambda *a, **k: {
        "out_dir": str(tmp_path / "s"), "cases": 2, "skipped": 0, "ran": 2, "seconds": 0.1,
        "startup_seconds": 0.1, "table": pd.DataFrame(rows)})
    assert main(["study", str(path), "--out", str(tmp_path / "s")]) == 1
    out = " ".join(capsys.readouterr().out.split())
    assert f"no case succeeded: all 2 cases failed: {why} ×2; no optimum, Pareto front or knee to report" in out
    assert "knee" not in out.replace("or knee", "") and "best optimum" not in out and "Pareto plot" not in out
    assert not (tmp_path / "s" / "pareto.png").exists()


@pytest.mark.slow
def test_worker_with_another_cvtdesign_version_is_refused(tmp_path, shared, capsys, monkeypatch):
    """Workers that run another version of cvtdesign than the client (here: the client says 0.0.0) are
    refused in one line when they are warmed, before any case runs."""
    monkeypatch.setattr(study_mod, "metadata", SimpleNamespace(version=lambda package: "0.0.0"))
    assert main(["study", str(small_study(tmp_path)), "--out", str(tmp_path / "s"), "--scheduler", shared]) == 2
    one_line(capsys.readouterr().err, f"cvtdesign: error: --scheduler {shared}: a worker cannot run this study's "
             "cases (RuntimeError: worker tcp://", "the client 0.0.0); expected cvtdesign 0.0.0 installed on every worker")
    assert case_files(tmp_path / "s") == []


def test_local_workers_run_without_the_statistical_profiler(shared):
    """cluster.local_cluster's workers do not sample their stacks for the dashboard's profile page (a few % of
    the cases' time on 2 cores), and this process's Dask settings are left as they were."""
    with Client(shared) as client:
        settings = client.run(lambda: dask.config.get("distributed.worker.profile.enabled"))
    assert len(settings) == 2 and not any(settings.values())
    assert dask.config.get("distributed.worker.profile.enabled") is True


def test_optimum_variant_files_are_the_model_that_was_optimised(tmp_path, shared):
    """A study's optimum is written as a variant file that `compare` reads back, with the study's effects
    (they were left out: a Pareto file of a loss study described a model without rolling resistance, 3.474°
    where the study had 3.452°) and its sweep point; its worst |α| over the study's envelope is the stored
    figure."""
    effects = ["drive_longitudinal_creep", "steering_lateral_creep", "rolling_resistance"]
    study = small_study(tmp_path, effects=effects, multistart={"starts": 1}, batch={"sweep": {"r_steer": ["30 mm"]}})
    res = run_study(load_study(study), tmp_path / "s", scheduler=shared)
    row = res["table"].iloc[0]
    assert row["success"], row["status"]
    layout = load_variant(row["variant_file"])
    assert list(layout.effects) == effects and layout.parameters["r_steer"] == pytest.approx(0.030)
    G, T = np.meshgrid(layout.gamma_grid, layout.load_grid, indexing="ij")
    alpha = compile_model(layout).evaluate(G, T)["alpha"]
    assert np.degrees(np.max(np.abs(alpha))) == pytest.approx(row["worst_alpha_deg"], rel=1e-6)


@pytest.mark.slow
def test_a_lost_scheduler_ends_the_run_with_one_line_and_keeps_what_finished(tmp_path, shared, capsys, monkeypatch):
    """Killing the scheduler mid-study printed distributed's traceback, stored 46 cases as
    'error: FutureCancelledError: …' (46 rows of the status table) and exited 0 with a 'best optimum' from
    2 of 48 starts. Cancelled cases are not stored now: one line says how many finished and are kept,
    exit 1, and a second run runs only the rest."""
    real = study_mod.as_completed

    def losing(futures):          # the scheduler goes away after two cases: the rest are cancelled
        for k, fut in enumerate(real(futures)):
            if k >= 2:
                fut.cancel()
            yield fut
    monkeypatch.setattr(study_mod, "as_completed", losing)
    study = small_study(tmp_path)
    assert main(["study", str(study), "--out", str(tmp_path / "s"), "--scheduler", shared]) == 1
    err = capsys.readouterr().err
    one_line(err, "cvtdesign: the cluster lost 4 of 6 cases", "2 finished and are kept in", "run again to resume")
    assert len(case_files(tmp_path / "s")) == 2
    monkeypatch.setattr(study_mod, "as_completed", real)
    res = run_study(load_study(study), tmp_path / "s", scheduler=shared)
    assert res["skipped"] == 2 and res["ran"] == 4 and res["table"]["success"].all()
