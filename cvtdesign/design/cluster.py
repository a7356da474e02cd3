"""Dask: a local cluster sized to the machine (one single-threaded worker process per core), or an existing
scheduler given by address; the same code runs on both.

Bad settings are one InputError line: `--workers` must be a positive integer (LocalCluster would wait
forever for -1 workers) and, for a local cluster, at most the cores this process may use (100,000 workers on
2 cores were still starting after 150 s), and a scheduler that does not answer within CONNECT_TIMEOUT
seconds is refused.
The local cluster's worker processes ignore Ctrl-C (SIGINT reaches the whole process group at a terminal):
only this process is interrupted, and it closes the cluster, with distributed's logging of the shutdown
silenced (`quiet_logs`), instead of every worker printing its own traceback.
"""
from __future__ import annotations

import asyncio
import logging
import signal
import threading
from contextlib import contextmanager, nullcontext

import dask
from dask.distributed import Client, LocalCluster
from distributed.core import rpc
from distributed.security import Security

from cvtdesign.errors import InputError
from cvtdesign.io import machine

CONNECT_TIMEOUT = 5.0   # seconds to wait for an existing scheduler to answer


def check_workers(workers, scheduler: str | None = None) -> None:
    """`--workers`: None (one per core) or a positive integer, for a local cluster at most the cores this
    process may use (io.machine.cores: each worker is single-threaded, more would only share them);
    `--scheduler`: None or an address (an empty one quietly started a local cluster)."""
    if scheduler is not None and not scheduler.strip():
        raise InputError("--scheduler: expected the address of a running scheduler, e.g. tcp://host:8786, got ''")
    if workers is None:
        return
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise InputError(f"--workers: expected a positive number of worker processes, got {workers}")
    if not scheduler and workers > machine.cores():
        raise InputError(f"--workers: {workers} worker processes on the {machine.cores()} cores this process may "
                         f"use; expected at most {machine.cores()} (each worker is single-threaded: more only share "
                         "the cores), or --scheduler for a cluster of more")


def connect(scheduler: str, timeout: float | None = None):
    """A Client on an existing scheduler; one InputError line if none answers within `timeout` seconds, or
    what answers is not a Dask scheduler (`_identify`)."""
    timeout = CONNECT_TIMEOUT if timeout is None else timeout
    why = _identify(scheduler, timeout)
    if why is None:
        try:
            return Client(scheduler, timeout=timeout)
        except (OSError, TimeoutError):
            why = f"no Dask scheduler answered within {timeout:g} s"
    raise InputError(f"--scheduler {scheduler}: {why}; expected the address of a running scheduler, "
                     "e.g. tcp://host:8786")


def _identify(scheduler: str, timeout: float) -> str | None:
    """Why `scheduler` is not a Dask scheduler that answers within `timeout` s, or None if it is. Asked with
    Dask's own `identity` call under a hard deadline: a Client waits forever on a port where something
    silent listens, and fails with a traceback on one that answers in another protocol."""
    async def identity():      # with the TLS settings of Dask's configuration, as a Client would use them
        async with rpc(scheduler, timeout=timeout, connection_args=Security().get_connection_args("client")) as r:
            return await r.identity()

    try:
        info = asyncio.run(asyncio.wait_for(identity(), timeout))
    except (OSError, TimeoutError, asyncio.TimeoutError):
        return f"no Dask scheduler answered within {timeout:g} s"
    except (ValueError, TypeError) as e:
        return f"not a scheduler address ({e})"
    except Exception as e:      # another protocol's reply, read as Dask's: any error at all
        return f"what answers there is not a Dask scheduler ({type(e).__name__})"
    kind = info.get("type") if isinstance(info, dict) else None
    return None if kind == "Scheduler" else f"what answers there is a Dask {kind or 'peer'}, not a scheduler"


def local_cluster(workers: int | None = None):
    """A LocalCluster of `workers` single-threaded worker processes (default: one per core), started with
    SIGINT ignored so that the worker processes inherit that and leave Ctrl-C to this process (a Ctrl-C
    during those ~1.5 s of start-up is therefore lost: press it again).

    Its workers run without Dask's statistical profiler, which samples each worker's stack every 10 ms for the
    dashboard's profile page: on 2 cores that took 3-5 % of the cases' time (benchmarks/bench_cluster.py).
    A cluster started by the user keeps the user's settings."""
    check_workers(workers)
    main = threading.current_thread() is threading.main_thread()
    old = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
    try:
        with dask.config.set({"distributed.worker.profile.enabled": False}):
            return LocalCluster(n_workers=workers or machine.cores(), threads_per_worker=1, processes=True,
                                dashboard_address=":0", silence_logs=logging.ERROR)
    finally:
        if main:
            signal.signal(signal.SIGINT, old)


@contextmanager
def quiet_logs():
    """No log records in this process inside the block (logging.disable): for the shutdown after Ctrl-C,
    whose connection errors distributed would log. The previous setting is restored afterwards."""
    before = logging.root.manager.disable
    logging.disable(logging.CRITICAL)
    try:
        yield
    finally:
        logging.disable(before)


def _close(client, cluster):
    client.close()
    if cluster is not None:
        cluster.close()


@contextmanager
def dask_client(scheduler: str | None = None, workers: int | None = None):
    """A dask.distributed Client: on `scheduler` if given, else on a LocalCluster started (and closed) here.
    On Ctrl-C (KeyboardInterrupt) the client and cluster are closed with distributed's logging silenced,
    and the KeyboardInterrupt goes on to the caller."""
    check_workers(workers, scheduler)
    cluster = None
    if scheduler:
        client = connect(scheduler)
    else:
        cluster = local_cluster(workers)
        try:
            client = Client(cluster)
        except BaseException:
            cluster.close()
            raise
    interrupted = False
    try:
        yield client
    except KeyboardInterrupt:
        interrupted = True
        raise
    finally:
        with quiet_logs() if interrupted else nullcontext():
            _close(client, cluster)
