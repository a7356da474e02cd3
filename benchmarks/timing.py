"""Timing helper shared by the benchmarks (the machine is shared and noisy: report the best of repeats)."""
import time


def best_of(fn, repeats):
    """(shortest wall time [s] of `repeats` calls of fn, the last result)."""
    times, out = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return min(times), out
