"""A study on a separately started Dask cluster: `dask scheduler` and two `dask worker` processes on
loopback, started in a folder of their own, as a user starts them on other machines. The study is given by
a relative path, names its variant files and calibration report relative to itself, and restricts a design
variable to one variant: none of these files exist where the workers run, so the study must travel as
content. Its results must equal those of a run on a local cluster, and the optimum's variant files must be
written here, by the client, naming the client's files.

The processes are started in sessions of their own and killed, with everything they started, whatever the
test does."""
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
import yaml
from dask.distributed import Client

from conftest import ROOT

from cvtdesign.cli import main
from cvtdesign.design.store import read_store

# the `dask` command of this Python's environment (beside its interpreter), else the first on PATH
DASK = shutil.which("dask", path=os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")]))
START_TIMEOUT = 60.0     # seconds for the scheduler and both workers to come up on a loaded machine


def stop(processes: list[subprocess.Popen]) -> None:
    """SIGTERM to each process's session (a worker's nanny and the worker it started), SIGKILL to any left
    after 5 s."""
    for p in processes:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGTERM)
    deadline = time.monotonic() + 5
    for p in processes:
        try:
            p.wait(timeout=max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            pass
        if p.poll() is None or _group_alive(p.pid):
            _kill_group(p.pid)
            p.wait()


def _group_alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
        return True
    except ProcessLookupError:
        return False


def _kill_group(pgid: int) -> None:
    try:
        os.killpg(pgid, signal.SIGKILL)
    except ProcessLookupError:
        pass


@pytest.fixture
def dask_cluster(tmp_path):
    """The address of a scheduler with two single-threaded workers, all started with their working
    directory in a folder of their own (not the client's); the processes are gone after the test."""
    if DASK is None:
        pytest.skip(f"no dask command beside {sys.executable} or on PATH")
    where = tmp_path / "cluster"
    where.mkdir()
    address_file = where / "scheduler.json"
    run = dict(cwd=where, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    processes = []
    try:
        processes.append(subprocess.Popen([DASK, "scheduler", "--host", "127.0.0.1", "--port", "0",
                                           "--no-dashboard", "--scheduler-file", str(address_file)], **run))
        for _ in range(2):
            processes.append(subprocess.Popen([DASK, "worker", "--scheduler-file", str(address_file),
                                               "--nthreads", "1", "--no-dashboard", "--local-directory",
                                               str(where)], **run))
        yield processes, address_file
    finally:
        stop(processes)


def connect(processes, address_file: Path) -> str:
    """The scheduler's address once both workers have joined."""
    deadline = time.monotonic() + START_TIMEOUT
    while not address_file.exists():
        assert all(p.poll() is None for p in processes), "a dask process ended at start-up"
        assert time.monotonic() < deadline, "the scheduler did not start"
        time.sleep(0.1)
    address = json.loads(address_file.read_text())["address"]
    with Client(address, timeout=START_TIMEOUT) as client:
        client.wait_for_workers(2, timeout=max(1.0, deadline - time.monotonic()))
    return address


def client_folder(folder: Path) -> Path:
    """A project folder: studies/small.yaml naming ../variants/{box,existing}.yaml and ../fits/fit.json."""
    for sub in ("studies", "variants", "fits"):
        (folder / sub).mkdir(parents=True)
    for v in ("box_kim", "existing_kim"):
        shutil.copy(ROOT / f"variants/{v}.yaml", folder / f"variants/{v}.yaml")
    (folder / "fits/fit.json").write_text(json.dumps({"final_fit": {
        "drive_longitudinal_creep.scale": {"value": 1.2, "std": 0.01, "identifiable": True}}}))
    (folder / "studies/small.yaml").write_text(yaml.safe_dump({
        "name": "small", "base": "../variants/box_kim.yaml", "calibration": "../fits/fit.json",
        "design": {"r_steer": {"lower": "25 mm", "upper": "45 mm"},
                   "d": {"lower": "30 mm", "upper": "110 mm", "variants": ["../variants/box_kim.yaml"]}},
        "envelope": {"gamma": {"start": "-60 deg", "stop": "60 deg", "step": "60 deg"},
                     "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "2 N*m"}},
        "multistart": {"starts": 2, "seed": 2},
        "batch": {"variants": ["../variants/box_kim.yaml", "../variants/existing_kim.yaml"]}}))
    return folder


def results(store: Path) -> pd.DataFrame:
    df = read_store(store)
    cols = ["case_id", "status", "success", "objective", "design.r_steer", "design.d"]
    return df[cols].sort_values("case_id").reset_index(drop=True)


@pytest.mark.slow
def test_relative_study_on_a_separate_cluster_equals_a_local_run(tmp_path, monkeypatch, capsys, dask_cluster):
    here = client_folder(tmp_path / "project")
    monkeypatch.chdir(here)
    assert main(["study", "studies/small.yaml", "--out", "local", "--workers", "1"]) == 0
    address = connect(*dask_cluster)
    capsys.readouterr()
    assert main(["study", "studies/small.yaml", "--out", "remote", "--scheduler", address]) == 0
    out = capsys.readouterr().out
    assert "4 cases: 0 already in remote, 4 run" in out and "failed" not in out, out
    remote, local = results(here / "remote"), results(here / "local")
    assert remote["success"].all() and len(remote) == 4
    pd.testing.assert_frame_equal(remote, local, rtol=1e-9)
    # the optimum's variant files: written here, naming the client's files, carrying the calibration
    files = read_store(here / "remote")["variant_file"]
    assert all(f.startswith(os.path.join("remote", "variants", "small_")) for f in files)
    text = (here / files.iloc[0]).read_text()
    assert "# Optimised by `cvtdesign study studies/small.yaml`" in text
    assert "# base variant: studies/../variants/" in text and "# calibration: ../fits/fit.json" in text
    assert yaml.safe_load(text)["effect_parameters"]["drive_longitudinal_creep"]["scale"] == 1.2
    assert not any(p.suffix == ".yaml" for p in (tmp_path / "cluster").rglob("*"))     # nothing written there
