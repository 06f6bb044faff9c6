"""Dask clusters for `pmmw sweep` and `pmmw render --executor dask`.

One place decides which cluster a command talks to: a batch-queue cluster from a dask-jobqueue
file (``--cluster slurm.yaml``), a running scheduler (``--scheduler tcp://host:8786``), or a
`LocalCluster` of single-threaded worker processes on this machine. A task that dies with its
worker is rescheduled by the scheduler (up to ``distributed.scheduler.allowed-failures`` times,
3 by default). pmmw's tasks never raise: they return an error as text, because an exception
whose traceback does not pickle can leave the client waiting forever.

Every connection has a deadline. Dask's own connect retries until its timeout but then waits for
the other side's handshake without one: an HTTP server, or a port that accepts and says nothing,
held ``pmmw render --scheduler`` for good, and a service that sends other bytes made Dask read a
length of exabytes from them (a MemoryError). So `probe_scheduler` first talks to a ``tcp://``
address with a plain socket: a Dask scheduler greets first, at once, with its handshake (an
8-byte length and a msgpack mapping of a few dozen bytes, `distributed.comm.core.connect`); an
address that refuses, stays silent for `CONNECT_S`, answers like an HTTP server or sends anything
else is a `UserError` (exit status 2: the address the user gave is wrong) naming the address and
the cause, in one line. A scheduler that goes away during a run (its futures are cancelled,
`scheduler_lost`), or a cluster without a worker to take the job, is an `EnvironmentProblem`
(exit status 1: the address was right, the machines failed) raised by the render or the sweep
with what was finished. While pmmw holds a cluster (`dask_client`), distributed's, tornado's and
bokeh's loggers print nothing (`quiet_dask_logs`): pmmw says what went wrong itself.

No task writes into the output folder: a render's tasks return their tiles, which pmmw saves
(`trace.pool`), and a sweep's render their variant in the worker's own temporary folder and return
its files, which pmmw moves into place (`sweep.render_variant`). A worker goes on with the task it
has begun when its scheduler dies or pmmw stops, and nothing can stop it; this way it cannot
change the output after pmmw returned.
"""

from __future__ import annotations

import contextlib
import logging
import re
import socket
import struct
import time
import warnings
from pathlib import Path

from pmmw.errors import UserError, warn
from pmmw.io.yamlio import read_yaml

EXECUTORS = ("local", "dask")  # where `pmmw render` and `pmmw sweep` run their work
CLUSTER_KINDS = {"slurm": "SLURMCluster", "pbs": "PBSCluster", "sge": "SGECluster", "lsf": "LSFCluster"}

#: How long a scheduler's address has to accept a connection and greet, then the client to
#: register [s]. A scheduler greets within milliseconds; this leaves room for a loaded one.
CONNECT_S = 10.0
#: After `CONNECT_S` of silence, how long an HTTP request waits for an answer that names the
#: service behind the address [s].
HTTP_PROBE_S = 2.0
#: The longest greeting taken for Dask's [bytes]: its handshake is about 60 bytes.
GREETING_MAX = 1 << 16
#: How long closing the client, and a cluster pmmw started, may take before it is left [s].
CLOSE_S = 10.0
#: The loggers that print Dask's log lines and tracebacks to the terminal (`quiet_dask_logs`).
DASK_LOGGERS = ("distributed", "tornado", "bokeh", "asyncio")


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


def _scheduler_host_port(address: str) -> tuple[str, str, int | None]:
    """(scheme, host, port) of a scheduler address (``tcp://`` when none is given); port None
    for the schemes other than tcp, which `probe_scheduler` does not talk to."""
    from distributed.comm.registry import backends

    m = re.fullmatch(r"(?:([A-Za-z][A-Za-z0-9+.-]*)://)?(.*)", address.strip())
    scheme, rest = (m.group(1) or "tcp").lower(), m.group(2)
    if scheme in ("http", "https"):
        raise UserError(
            f"{address} is a web address (a dashboard's?); a scheduler's looks like tcp://HOST:8786", "--scheduler"
        )
    if scheme not in backends:
        raise UserError(
            f"{address}: unknown scheme {scheme!r}; a scheduler's address looks like tcp://HOST:8786", "--scheduler"
        )
    if scheme != "tcp":
        return scheme, rest, None
    host, sep, port = rest.rpartition(":")
    host = host[1:-1] if host.startswith("[") and host.endswith("]") else host  # [::1]:8786
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise UserError(f"{address}: expected tcp://HOST:PORT, e.g. tcp://head:8786", "--scheduler")
    return scheme, host, int(port)


def _receive(sock: socket.socket, n: int, deadline: float) -> tuple[bytes, bool]:
    """Up to ``n`` bytes from ``sock`` before ``deadline`` (`time.monotonic`); (data, whether
    the deadline passed first). Fewer bytes without the deadline: the other side closed."""
    data = b""
    while len(data) < n:
        left = deadline - time.monotonic()
        if left <= 0:
            return data, True
        sock.settimeout(left)
        try:
            chunk = sock.recv(n - len(data))
        except TimeoutError:
            return data, True
        except OSError:  # reset
            return data, False
        if not chunk:
            return data, False
        data += chunk
    return data, False


def _answers_http(sock: socket.socket) -> bool:
    """Does the silent service behind ``sock`` answer an HTTP request like an HTTP server?"""
    try:
        sock.sendall(b"GET / HTTP/1.0\r\n\r\n")
    except OSError:
        return False
    data, _ = _receive(sock, 5, time.monotonic() + HTTP_PROBE_S)
    return data == b"HTTP/"


def _is_handshake(body: bytes) -> bool:
    """Is ``body`` (after its 8-byte length) a Dask handshake: frames whose first is a msgpack
    mapping (`distributed.comm.core.Comm.handshake_info`)?"""
    import msgpack
    from distributed.protocol.utils import unpack_frames

    try:
        return isinstance(msgpack.loads(bytes(unpack_frames(body)[0])), dict)
    except Exception:  # noqa: BLE001 - anything else is not a handshake
        return False


def _shown(data: bytes) -> str:
    text = data[:24].decode("ascii", "replace")
    return repr(text) if text.isprintable() else f"{len(data)}+ bytes of binary data"


def probe_scheduler(address: str, timeout: float = CONNECT_S) -> None:
    """Check that a Dask scheduler greets at ``address`` within ``timeout`` [s], with a plain socket.

    A ``tcp://`` scheduler speaks first: its handshake, an 8-byte length and a msgpack mapping of
    about 60 bytes, sent as soon as it accepts. The probe reads it, answers with the same
    handshake (so the scheduler's log records no broken connection) and closes. An address that
    stays silent is sent an HTTP request to name what is there. Other schemes (``tls://``, ...)
    are left to Dask, under its own timeout.

    Raises
    ------
    UserError
        One line naming the address and the cause: an unknown host, a refused connection, no
        answer within ``timeout``, or an answer that is not Dask's (an HTTP server's, other bytes).
    """
    _, host, port = _scheduler_host_port(address)
    if port is None:
        return
    deadline = time.monotonic() + timeout

    def fail(why: str) -> UserError:
        return UserError(f"{address} {why}", "--scheduler")

    try:
        sock = socket.create_connection((host, port), timeout=timeout)
    except socket.gaierror as e:
        raise fail(f"names a host that cannot be found ({e.strerror})") from None
    except ConnectionRefusedError:
        raise fail(
            "refused the connection: no Dask scheduler listens there (start one with `dask scheduler`, "
            "or correct the address)"
        ) from None
    except TimeoutError:
        raise fail(f"did not answer within {timeout:g} s") from None
    except OSError as e:
        raise fail(f"cannot be reached: {e.strerror or e}") from None
    with sock:
        head, late = _receive(sock, 8, deadline)
        if late and not head:
            if _answers_http(sock):
                raise fail(
                    "is not a Dask scheduler (it answered like an HTTP server; a scheduler listens on "
                    "port 8786 by default, its dashboard on 8787)"
                )
            raise fail(
                f"did not answer within {timeout:g} s (it accepts connections but says nothing; a Dask "
                "scheduler greets at once)"
            )
        if head.startswith(b"HTTP/"):
            raise fail("is not a Dask scheduler (it answered like an HTTP server)")
        if len(head) < 8:
            raise fail(
                "is not a Dask scheduler (it closed the connection without the Dask handshake)"
                if not late
                else f"did not finish its greeting within {timeout:g} s: not a Dask scheduler"
            )
        (n,) = struct.unpack("Q", head)
        if not 0 < n <= GREETING_MAX:
            raise fail(f"is not a Dask scheduler (it sent {_shown(head)}, not the Dask handshake)")
        body, late = _receive(sock, n, deadline)
        if len(body) < n:
            raise fail(
                f"did not finish its greeting within {timeout:g} s: not a Dask scheduler"
                if late
                else "is not a Dask scheduler (it closed the connection within the Dask handshake)"
            )
        if not _is_handshake(body):
            raise fail(f"is not a Dask scheduler (it sent {_shown(head + body)}, not the Dask handshake)")
        with contextlib.suppress(OSError):
            sock.sendall(head + body)


@contextlib.contextmanager
def quiet_dask_logs():
    """Nothing from `DASK_LOGGERS` reaches the terminal during the block (not even through the
    root logger): a lost scheduler made distributed print about 35 lines of traceback before
    pmmw's own line. Their handlers and settings are restored after."""
    import distributed  # noqa: F401 - importing it adds its handlers: first, so that they are quieted too

    names = [
        n
        for n in list(logging.root.manager.loggerDict)
        if n in DASK_LOGGERS or n.startswith(tuple(f"{d}." for d in DASK_LOGGERS))
    ]
    handlers = {h for n in names for h in logging.getLogger(n).handlers}  # distributed gives its children one too
    levels = {h: h.level for h in handlers}
    saved = []
    for name in DASK_LOGGERS:
        logger = logging.getLogger(name)
        sink = logging.NullHandler()  # a logger with no handler would print through logging.lastResort
        saved.append((logger, logger.propagate, sink))
        logger.propagate = False
        logger.addHandler(sink)
    for h in handlers:
        h.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for logger, propagate, sink in saved:
            logger.removeHandler(sink)
            logger.propagate = propagate
        for h, level in levels.items():
            h.setLevel(level)


def connect(scheduler: str | None, cluster_file: Path | None, n_local: int):
    """(client, cluster): a Dask client of the job-queue cluster of ``cluster_file``, else of the
    scheduler at ``scheduler`` (`probe_scheduler` first), else of a new `LocalCluster` of
    ``n_local`` single-threaded worker processes. ``cluster`` is the one this call started
    (close it after the client), or None. Use `dask_client`, which also closes them."""
    from dask.distributed import Client, LocalCluster

    if cluster_file is not None:
        cluster = jobqueue_cluster(cluster_file)
        cluster.scale(jobs=int(read_yaml(cluster_file, "cluster file").get("jobs", 1)))
        return Client(cluster), cluster
    if scheduler:
        probe_scheduler(scheduler)
        with warnings.catch_warnings(record=True) as seen:  # a version mismatch: a table of versions
            warnings.simplefilter("always")
            try:
                client = Client(scheduler, timeout=f"{CONNECT_S}s")
            except Exception as e:  # noqa: BLE001 - it greeted like Dask but did not take a client
                text = str(e).strip().splitlines()[0][:200] if str(e).strip() else ""
                raise UserError(
                    f"{scheduler} greeted like Dask but did not take a client within {CONNECT_S:g} s "
                    f"({type(e).__name__}{': ' + text if text else ''}): is it a scheduler's address, "
                    "not a worker's?",
                    "--scheduler",
                ) from None
        for w in seen:
            first = str(w.message).strip().splitlines()
            warn(f"Dask at {scheduler}: {first[0] if first else type(w.message).__name__}")
        return client, None
    cluster = LocalCluster(n_workers=max(1, n_local), threads_per_worker=1, processes=True, dashboard_address=None)
    return Client(cluster), cluster


@contextlib.contextmanager
def dask_client(scheduler: str | None, cluster_file: Path | None, n_local: int):
    """``with dask_client(...) as client:`` the client of `connect`, with Dask's loggers quiet
    (`quiet_dask_logs`); on the way out the client, then any cluster pmmw started, are closed,
    each within `CLOSE_S` (a scheduler that went away cannot hold pmmw)."""
    with quiet_dask_logs():
        client, cluster = connect(scheduler, cluster_file, n_local)
        try:
            yield client
        finally:
            for thing in (client, cluster):
                if thing is None:
                    continue
                with contextlib.suppress(Exception):  # nothing left to save: it is being let go
                    thing.close(timeout=CLOSE_S)


#: How long `scheduler_lost` waits for the scheduler's greeting after a connection closed under a
#: result [s]: a scheduler that is there greets at once.
LOST_PROBE_S = 2.0


def scheduler_lost(client, error: BaseException | None = None) -> bool:
    """Has ``client`` lost its scheduler? Dask then cancels every future of the client
    (``scheduler-connection-lost``) and tries to reconnect. A connection that closed under a
    result (``error`` an `OSError`, as Dask's ``CommClosedError``) can come before the client has
    noticed the loss: then the scheduler's address is asked (`probe_scheduler`, `LOST_PROBE_S`),
    so that a dead scheduler is not blamed on the tile whose result was in flight."""
    if client.status != "running" or getattr(error, "reason", None) == "scheduler-connection-lost":
        return True
    if isinstance(error, OSError):
        try:
            probe_scheduler(client.scheduler.address, timeout=LOST_PROBE_S)
        except UserError:
            return True
    return False


def cancel_quietly(client, futures) -> None:
    """Cancel ``futures`` if the scheduler is still there to hear it (a task already running ends
    on its own; its result is dropped)."""
    if client.status != "running":
        return
    with contextlib.suppress(Exception):  # the scheduler went away meanwhile
        client.cancel(list(futures))
