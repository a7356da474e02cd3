"""Dask: a local cluster sized to the machine (one single-threaded worker process per core), or an existing
scheduler given by address; the same code runs on both."""
from __future__ import annotations

import os
from contextlib import contextmanager


@contextmanager
def dask_client(scheduler: str | None = None, workers: int | None = None):
    """A dask.distributed Client: on `scheduler` if given, else on a LocalCluster started (and closed) here."""
    from dask.distributed import Client, LocalCluster

    cluster = None
    if scheduler:
        client = Client(scheduler)
    else:
        cluster = LocalCluster(n_workers=workers or os.cpu_count(), threads_per_worker=1, processes=True,
                               dashboard_address=":0", silence_logs=40)
        client = Client(cluster)
    try:
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
