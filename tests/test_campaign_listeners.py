"""A local campaign lets no one in: every socket its cluster listens on is on loopback, and
Dask's dashboard is served only when asked for (``--dashboard``), on loopback unless a host is named."""
from __future__ import annotations

import os
import urllib.error
import urllib.request
from pathlib import Path

import pytest

from wheelleg.hil.campaign import execution

pytestmark = pytest.mark.slow  # a local Dask cluster of worker processes


def _socket_inodes(pid: int) -> set[int]:
    inodes = set()
    for fd in Path(f"/proc/{pid}/fd").glob("*"):
        try:
            target = os.readlink(fd)
        except OSError:  # closed meanwhile
            continue
        if target.startswith("socket:["):
            inodes.add(int(target[8:-1]))
    return inodes


def _family(pid: int) -> set[int]:
    """``pid`` and every process below it (the cluster's scheduler, nannies, workers)."""
    children = {p: int(Path(f"/proc/{p}/stat").read_text().rsplit(")", 1)[1].split()[1])
                for p in map(int, filter(str.isdigit, os.listdir("/proc"))) if Path(f"/proc/{p}/stat").exists()}
    family, grew = {pid}, True
    while grew:
        more = {p for p, parent in children.items() if parent in family} - family
        family |= more
        grew = bool(more)
    return family


def _listening(pids: set[int]) -> list[str]:
    """'ADDRESS:PORT' (hex, as /proc/net/tcp{,6} has them) of every TCP socket of ``pids`` that listens."""
    inodes = set().union(*(_socket_inodes(p) for p in pids))
    found = []
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        for line in Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            if fields[3] == "0A" and int(fields[9]) in inodes:  # 0A: LISTEN
                found.append(fields[1])
    return found


LOOPBACK_HEX = ("0100007F:", "00000000000000000000000001000000:")  # 127.0.0.1, ::1


@pytest.mark.skipif(not Path("/proc/net/tcp").exists(), reason="reads Linux's /proc/net/tcp")
@pytest.mark.parametrize("dashboard", [None, ""], ids=["no-dashboard", "dashboard"])
def test_every_listener_of_a_local_campaign_is_on_loopback(dashboard):
    with execution.Engine(workers=1, dashboard=execution.dashboard_address(dashboard)) as engine:
        listening = _listening(_family(os.getpid()))
        # the scheduler's HTTP server is always there (health, metrics); the dashboard's pages only when asked
        port = engine.client.scheduler_info()["services"]["dashboard"]
        status = _status(f"http://127.0.0.1:{port}/status")
        link = engine.client.dashboard_link
        # one worker per core, single-threaded: no BLAS pool of a core's count in each
        pools = engine.client.run(lambda: [os.environ.get(k) for k in execution.WORKER_ENV])
    assert all(values == ["1"] * len(execution.WORKER_ENV) for values in pools.values()), pools
    assert len(listening) >= 3  # the scheduler, the worker, its nanny
    assert all(address.startswith(LOOPBACK_HEX) for address in listening), listening
    assert status == (404 if dashboard is None else 200)
    assert link.startswith(f"http://127.0.0.1:{port}/")


def _status(url: str) -> int:
    try:
        with urllib.request.urlopen(url, timeout=30) as response:
            return response.status
    except urllib.error.HTTPError as exc:
        return exc.code


@pytest.mark.parametrize("text, address", [(None, None), ("", "127.0.0.1:0"), ("8787", "127.0.0.1:8787"),
                                           ("0.0.0.0:8787", "0.0.0.0:8787")])
def test_the_dashboard_is_loopback_unless_a_host_is_named(text, address):
    assert execution.dashboard_address(text) == address


@pytest.mark.parametrize("text", ["http", "host:port", "99999"])
def test_a_bad_dashboard_address_is_a_one_line_error(text):
    with pytest.raises(ValueError, match="--dashboard"):
        execution.dashboard_address(text)


def test_without_a_dashboard_the_schedulers_http_server_takes_a_free_loopback_port():
    """Dask puts the scheduler's HTTP server (health, metrics) on 8787 and warns "Port 8787 is
    already in use" when a second campaign runs: without a dashboard it asks for a free port."""
    options = execution.cluster_options(2, True, None)
    assert options["scheduler_kwargs"] == {"dashboard": False, "dashboard_address": "127.0.0.1:0"}
    assert options["host"] == "127.0.0.1" and options["n_workers"] == 2 and options["threads_per_worker"] == 1
    asked = execution.cluster_options(1, True, "127.0.0.1:8787")
    assert "scheduler_kwargs" not in asked and asked["dashboard_address"] == "127.0.0.1:8787"
