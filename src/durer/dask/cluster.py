"""Which `distributed` cluster to run on: the active client, or one named by `--scheduler` (an address, or
`local:N` for a LocalCluster of N single-thread worker processes on 127.0.0.1).

A scheduler that cannot be reached ends in a ValueError after CONNECT_TIMEOUT seconds, never a hang, so the
command line reports it in one line (exit 2).
"""

from __future__ import annotations

import contextlib
import os
import re
from collections.abc import Iterator

CONNECT_TIMEOUT = 10.0  # seconds to reach a scheduler before giving up
_ADDRESS = re.compile(r"^(tcp|tls|inproc|ucx|ws|wss)://[^\s/:]+(:\d{1,5})?$")


def active_client():
    """The active distributed client, or None (threads or processes of the local scheduler)."""
    try:
        from distributed import get_client
    except ImportError:
        return None
    try:
        return get_client()
    except ValueError:
        return None


def parse_scheduler(spec: str) -> str | int:
    """'local:N' -> N (worker processes), 'tcp://HOST:PORT' -> the address; ValueError naming the spec otherwise."""
    if spec.startswith("local:"):
        n = spec[len("local:"):]
        if not n.isdigit() or int(n) < 1:
            raise ValueError(f"--scheduler {spec!r}: local:N needs a positive number of workers")
        return int(n)
    if not _ADDRESS.match(spec):
        raise ValueError(f"--scheduler {spec!r}: expected a scheduler address such as tcp://HOST:8786, or local:N")
    return spec


def cores() -> int:
    """CPU cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


@contextlib.contextmanager
def connect(spec: str, timeout: float | None = None) -> Iterator:
    """A distributed Client for `spec` (parse_scheduler), closed (and a local cluster stopped) on exit.
    local:N workers each get cores // N Numba threads, so N workers do not oversubscribe the machine."""
    target = parse_scheduler(spec)
    timeout = CONNECT_TIMEOUT if timeout is None else timeout
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise ValueError("--scheduler needs distributed (pip install 'durer[dask]')") from None
    if isinstance(target, int):
        env = {"NUMBA_NUM_THREADS": str(max(1, cores() // target))}
        with LocalCluster(n_workers=target, threads_per_worker=1, processes=True, host="127.0.0.1",
                          dashboard_address=None, silence_logs=40, env=env) as cluster, Client(cluster) as client:
            yield client
        return
    try:
        client = Client(target, timeout=timeout)
    except (OSError, TimeoutError) as e:
        reason = (str(e).splitlines() or [type(e).__name__])[0]
        raise ValueError(f"--scheduler {spec}: cannot reach the scheduler ({reason})") from None
    with client:
        yield client
