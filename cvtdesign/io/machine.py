"""What this machine has for a run, read before a command starts one: the cores this process may use and the
memory still free. Sizes a command would run beyond them (local Dask workers, envelope points) are refused
in one InputError line that gives the limit (design.cluster, io.limits)."""
from __future__ import annotations

import os


def cores() -> int:
    """The CPU cores this process may run on (its affinity: a batch job's share, not the whole node)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def free_memory() -> int | None:
    """Memory available to a new computation [bytes] (Linux: MemAvailable, the free memory plus the caches
    the kernel would give up); None where the system does not say."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None
