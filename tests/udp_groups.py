"""A udp_multicast pair number (its groups and ports) that no other test on this machine uses while it holds it.

python-can's ``udp_multicast`` bus binds ``("", port)`` with SO_REUSEADDR/SO_REUSEPORT and joins
a group, so two runs on one group and port hear each other's frames and neither fails cleanly:
a run reads the other's commands, its program gets two SYNCs a tick. Drawing the group at random
per worker (a pid-seeded start in one range, as ``test_programs`` did) let the two xdist workers
of one session, or the workers of two sessions on one shared machine, walk onto the same group.

Here a worker starts at its own offset (``PYTEST_XDIST_WORKER``'s number), so the workers of one
session do not even contend, and a pair is held by an exclusive ``flock`` on a file named after
its number in the machine's temporary folder: another session's worker, or a second claim in this
process, finds it taken and moves on. The kernel drops the lock when the file is closed or the
process dies, so a killed test leaves nothing held.

The lock is the number's, not a group's: python-can binds ``("", port)`` and Linux hands such a
socket every group's datagrams to that port that any socket on the host joined, so the ports
must be as unique as the groups. Callers make both from the number (``PREFIX.N``, ``PREFIX.N+1``,
a port from N), so one number is one test's groups and ports whatever its prefix.
"""
from __future__ import annotations

import fcntl
import os
import re
import tempfile
from contextlib import contextmanager
from pathlib import Path

FIRST, LAST, STRIDE = 100, 254, 2  # pair numbers: groups PREFIX.N and PREFIX.N+1 for N in FIRST..LAST-2
WORKER_SPACING = 8  # pairs between two workers' starting points (a file's claims in one session fit in it)


def worker_number(worker: str | None = None) -> int:
    """0 for ``gw0`` or no xdist, N for ``gwN``."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "") if worker is None else worker
    match = re.fullmatch(r"gw(\d+)", worker)
    return int(match.group(1)) if match else 0


def candidates(worker: str | None = None) -> list[int]:
    """Every pair's base, starting at this worker's offset and wrapping round."""
    bases = list(range(FIRST, LAST, STRIDE))
    start = (worker_number(worker) * WORKER_SPACING) % len(bases)
    return bases[start:] + bases[:start]


@contextmanager
def claimed_pair(worker: str | None = None, folder: Path | None = None):
    """Yield a pair number N held for the block (the caller's groups ``PREFIX.N``, ``PREFIX.N+1``)."""
    folder = Path(tempfile.gettempdir()) / "wheelleg-hil-udp-groups" if folder is None else folder
    folder.mkdir(parents=True, exist_ok=True)
    for base in candidates(worker):
        lock = open(folder / f"pair-{base}", "a")  # noqa: SIM115 (held open for the block)
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            lock.close()
            continue
        try:
            yield base
        finally:
            lock.close()
        return
    raise RuntimeError(f"every udp_multicast pair number {FIRST}-{LAST} is held by another test")
