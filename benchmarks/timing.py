"""Timing helper shared by the benchmarks (the machine is shared and noisy: report the best of repeats)."""
import resource
import subprocess
import time


def best_of(fn, repeats):
    """(shortest wall time [s] of `repeats` calls of fn, the last result)."""
    times, out = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return min(times), out


def run_timed(argv, cwd, env=None) -> tuple[float, float]:
    """(wall time, CPU time of the process and its children: user + system) [s] of running argv to its end in
    `cwd` (output captured; a failing command raises)."""
    r0, t = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
    subprocess.run(argv, cwd=cwd, check=True, capture_output=True, env=env)
    wall, r1 = time.perf_counter() - t, resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime
