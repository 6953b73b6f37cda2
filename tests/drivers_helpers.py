"""What the driver conformance tests share: ``wheelleg emulate`` in its own process on a fresh
udp_multicast group, and waiting for a condition."""
from __future__ import annotations

import os
import random
import subprocess
import sys
import time

import pytest

UDP_DEFAULT_PORT = 43113  # python-can's udp_multicast default: drivers that open their own bus use it


def eventually(condition, timeout_s: float = 5.0, what: str = ""):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.02)
    raise AssertionError(f"not within {timeout_s} s: {what}")


class Emulators:
    """Start ``wheelleg emulate FAMILY ...`` processes on one fresh multicast group; ``close`` ends them."""

    def __init__(self, port: int | None = None):
        rng = random.Random(os.getpid() ^ time.monotonic_ns())
        self.channel = f"239.255.{rng.randrange(1, 255)}.{rng.randrange(1, 255)}"
        self.port = rng.randrange(20000, 60000) if port is None else port
        self.procs: list[subprocess.Popen] = []

    @property
    def bus(self) -> dict:
        """python-can kwargs of the group."""
        return {"interface": "udp_multicast", "channel": self.channel, "port": self.port}

    def driver_bus(self):
        """A python-can bus on the group for a driver: echo-free, as SocketCAN is by default (python-can's
        multicast bus hears its own frames, which a driver would read as the motor's answer)."""
        from wheelleg.controller.bus_args import open_bus
        return open_bus(**self.bus)

    def start(self, family: str, *args: str) -> dict:
        cmd = [sys.executable, "-m", "wheelleg.hil.cli", "emulate", family, *args,
               "-i", "udp_multicast", "-c", self.channel, "--bus-kwargs", f"port={self.port}"]
        proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True)
        line = proc.stderr.readline()
        assert "Ctrl-C stops" in line, line + proc.stderr.read()
        self.procs.append(proc)
        return self.bus

    def close(self) -> None:
        for proc in self.procs:
            proc.terminate()
            proc.wait(timeout=10)


@pytest.fixture
def emulators():
    """An ``Emulators`` for one test (import it into the test module to use it)."""
    emu = Emulators()
    yield emu
    emu.close()
