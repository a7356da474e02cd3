"""A batch study on 1 and 2 Dask workers: the speed-up, with and without the cluster's start-up.

The study is studies/bench_32.yaml: the box CVT's placement and radii under Kalker's contact theory, 8 starts
at each of 4 preloads, 32 cases of about 0.5 s on a quiet machine, 4 distinct problems. Each run is the
whole `run_study` on a LocalCluster of its own (`--workers 1`, then `--workers 2`, alternating, into a new
store each time), best of REPEATS of each measure:
  (a) the cases alone: from the first case submitted to the last case's file written (goal ≥ 1.8×);
  (b) the whole run: cluster start-up (worker processes, imports, solver plugins), the cases and the
      cluster's shutdown, what a user waits for (goal ≥ 1.5×).
The ratio of each repeat's two runs, made back to back, is printed too: when the load changes during the
benchmark, the two best-of figures may come from different loads. Also printed: the cases' own times (measured in the workers, a problem's build included in the first case
that needs it), how busy the workers were during (a), what these two cores give the same cases without Dask
(1 and 2 plain processes, warmed the same way, 8 cases of one problem per task), and the load average
before and after (the machine is shared: under load the second worker gets less than a core and the ratios
fall).

Run: python benchmarks/bench_cluster.py [REPEATS]
"""
import functools
import multiprocessing
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from cvtdesign.design.cases import make_cases, study_content
from cvtdesign.design.study import run_case, run_study, warm_worker
from cvtdesign.design.study_file import load_study

ROOT = Path(__file__).resolve().parents[1]
STUDY = ROOT / "studies/bench_32.yaml"
REPEATS = 5
GOALS = {"cases": 1.8, "whole": 1.5}


def one_run(workers: int, out: Path) -> dict:
    t = time.perf_counter()
    res = run_study(load_study(STUDY), out, workers=workers)
    whole = time.perf_counter() - t
    table = res["table"].drop_duplicates("case_id")
    assert len(table) == 32 and table["success"].all(), table["status"].value_counts()
    return {"whole": whole, "cases": res["seconds"], "startup": res["startup_seconds"],
            "case_seconds": table["seconds"].to_numpy()}


def plain_processes(workers: int, out: Path) -> float:
    """The cases' wall time in `workers` plain processes (no Dask): the study's content and cases as
    `run_study` makes them, 8 cases of one problem per task, every process started and warmed first."""
    study = load_study(STUDY)
    cases = make_cases(study)
    content = study_content(study, cases)
    with multiprocessing.get_context("spawn").Pool(workers, initializer=warm_worker) as pool:
        pool.map(time.sleep, [0.3] * (2 * workers), chunksize=1)
        t = time.perf_counter()
        pool.map(functools.partial(run_case, content, out_dir=str(out)), cases, chunksize=8)
        return time.perf_counter() - t


def verdict(ratio: float, goal: float) -> str:
    return f"{ratio:5.2f} ×   goal ≥ {goal} ×   {'met' if ratio >= goal else 'not met'}"


def main(repeats: int = REPEATS):
    load_before = os.getloadavg()
    runs = {1: [], 2: []}
    with tempfile.TemporaryDirectory() as tmp:
        for rep in range(repeats):
            for w in ((1, 2) if rep % 2 == 0 else (2, 1)):
                runs[w].append(one_run(w, Path(tmp) / f"w{w}_{rep}"))
                runs[w][-1]["plain"] = plain_processes(w, Path(tmp))
    load_after = os.getloadavg()
    best = {w: {k: min(r[k] for r in rs) for k in ("whole", "cases", "startup", "plain")} for w, rs in runs.items()}
    print(f"32-case study ({STUDY.relative_to(ROOT)}), LocalCluster of 1 and 2 single-threaded worker processes, "
          f"best of {repeats}")
    print(f"  load average before {load_before[0]:.2f} / {load_before[1]:.2f} / {load_before[2]:.2f} "
          f"(1 / 5 / 15 min), after {load_after[0]:.2f} / {load_after[1]:.2f} / {load_after[2]:.2f}")
    print(f"  {'':34s} {'1 worker':>9s} {'2 workers':>10s}")
    print(f"  {'cluster start-up':34s} {best[1]['startup']:8.2f}s {best[2]['startup']:9.2f}s")
    print(f"  {'the cases':34s} {best[1]['cases']:8.2f}s {best[2]['cases']:9.2f}s")
    print(f"  {'whole run (start-up, shutdown)':34s} {best[1]['whole']:8.2f}s {best[2]['whole']:9.2f}s")
    for w, rs in runs.items():
        fastest = min(rs, key=lambda r: r["cases"])
        s = fastest["case_seconds"]
        busy = s.sum() / (w * fastest["cases"])
        print(f"  {w} worker(s), fastest run: case times {s.min():.2f} / {np.median(s):.2f} / {s.max():.2f} s "
              f"(min / median / max), sum {s.sum():.1f} s; workers busy {busy:.0%} of the cases' wall time")
    print(f"  reference, the same cases in plain processes (no Dask): {best[1]['plain']:.2f} s → {best[2]['plain']:.2f} s, "
          f"{best[1]['plain'] / best[2]['plain']:.2f} × (what these 2 cores give these cases)")
    for k, what in (("cases", "cases"), ("whole", "whole runs"), ("plain", "plain processes")):
        pairs = sorted(a[k] / b[k] for a, b in zip(runs[1], runs[2]))
        print(f"  ratio of each repeat's 1- and 2-worker runs, {what}: {' '.join(f'{r:.2f}' for r in pairs)} "
              "(run back to back: less affected by a load that changes during the benchmark than the best-of ratio)")
    print(f"  (a) speed-up of the cases alone:        {verdict(best[1]['cases'] / best[2]['cases'], GOALS['cases'])}")
    print(f"  (b) speed-up of the whole run:          {verdict(best[1]['whole'] / best[2]['whole'], GOALS['whole'])}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else REPEATS)
