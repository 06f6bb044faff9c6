"""Dask clusters for `pmmw sweep` and `pmmw render --executor dask`.

One place decides which cluster a command talks to: a batch-queue cluster from a dask-jobqueue
file (``--cluster slurm.yaml``), a running scheduler (``--scheduler tcp://host:8786``), or a
`LocalCluster` of single-threaded worker processes on this machine. A task that dies with its
worker is rescheduled by the scheduler (up to ``distributed.scheduler.allowed-failures`` times,
3 by default). pmmw's tasks never raise: they return an error as text, because an exception
whose traceback does not pickle can leave the client waiting forever.
"""

from __future__ import annotations

from pathlib import Path

from pmmw_cli.errors import UserError
from pmmw_cli.io.yamlio import read_yaml

EXECUTORS = ("local", "dask")  # where `pmmw render` and `pmmw sweep` run their work
CLUSTER_KINDS = {"slurm": "SLURMCluster", "pbs": "PBSCluster", "sge": "SGECluster", "lsf": "LSFCluster"}


def jobqueue_cluster(path: Path):
    """A dask-jobqueue cluster from a YAML file: ``kind`` (slurm, pbs, sge, lsf), ``queue``,
    ``cores``, ``memory``, ``walltime``, ``jobs``, and any other keyword of the cluster class."""
    import dask_jobqueue

    cfg = dict(read_yaml(path, "cluster file") or {})
    kind = str(cfg.pop("kind", "slurm")).lower()
    if kind not in CLUSTER_KINDS:
        raise UserError(f"unknown kind {kind!r}; known: {', '.join(CLUSTER_KINDS)}", path, "kind")
    cfg.pop("jobs", None)
    cfg.setdefault("processes", cfg.get("cores"))  # one single-threaded process per core: a render per process
    for key in ("cores", "memory"):
        if key not in cfg:
            raise UserError("required key missing", path, key)
    cls = getattr(dask_jobqueue, CLUSTER_KINDS[kind])
    try:
        return cls(**cfg)
    except (TypeError, ValueError) as e:
        raise UserError(f"dask-jobqueue refused it: {e}", path) from None


def connect(scheduler: str | None, cluster_file: Path | None, n_local: int):
    """(client, cluster): a Dask client of the job-queue cluster of ``cluster_file``, else of the
    scheduler at ``scheduler``, else of a new `LocalCluster` of ``n_local`` single-threaded worker
    processes. ``cluster`` is the one this call started (close it after the client), or None."""
    from dask.distributed import Client, LocalCluster

    if cluster_file is not None:
        cluster = jobqueue_cluster(cluster_file)
        cluster.scale(jobs=int(read_yaml(cluster_file, "cluster file").get("jobs", 1)))
        return Client(cluster), cluster
    if scheduler:
        try:
            return Client(scheduler, timeout="30s"), None
        except (OSError, TimeoutError, ValueError) as e:
            raise UserError(f"no Dask scheduler answered at {scheduler!r}: {e}", "--scheduler") from None
    cluster = LocalCluster(n_workers=max(1, n_local), threads_per_worker=1, processes=True, dashboard_address=None)
    return Client(cluster), cluster
