"""Shared fixtures: keep this small."""
from __future__ import annotations

import os
import sys
import uuid

import can
import pytest

import bytecode_cache
import throwaway_venv

# Bytecode under the temporary folder when the shell forbids it beside the sources (tests/bytecode_cache.py):
# set here, before the test modules are collected (pytest rewrites and caches them as Python does)
_PREFIX = bytecode_cache.outside_the_tree(os.environ)
if _PREFIX is not None:
    sys.pycache_prefix, sys.dont_write_bytecode = _PREFIX, False

# As `wheelleg` itself does (hil/cli.py): no test renders, and without this MuJoCo loads an OpenGL
# back end (glfw) on import, 0.1-0.2 s in each xdist worker and in each process a test starts
os.environ.setdefault("MUJOCO_GL", "disable")


@pytest.fixture
def vbus_pair():
    """(driver, device) python-can virtual buses on a channel no other test uses.

    The virtual bus hands a sent frame to the other bus at once, so a test
    can send, ``service`` a node and ``recv(timeout=0)`` without threads.
    """
    channel = f"test-{uuid.uuid4().hex}"
    buses = (can.Bus(interface="virtual", channel=channel), can.Bus(interface="virtual", channel=channel))
    yield buses
    for bus in buses:
        bus.shutdown()


@pytest.fixture(scope="session")
def checkout_wheel(tmp_path_factory):
    """This checkout's wheel, built once a session (its tests share one xdist worker:
    ``sharing.BUILDS_THE_SOURCE_TREE``)."""
    return throwaway_venv.build_wheel(tmp_path_factory.mktemp("wheel"))


def _is_long(item) -> bool:
    """A scenario run (``rig_run``) or a test marked ``slow`` (seconds each)."""
    return "rig_run" in getattr(item, "fixturenames", ()) or item.get_closest_marker("slow") is not None


def pytest_collection_modifyitems(config, items):
    """Long tests first, otherwise in collection order.

    pytest-xdist hands the tests out in this order: with the long ones first, the
    thousands of short ones fill both workers to the end. In file order the scenario
    files came last and one worker ran the last 10-20 s runs alone.
    """
    items.sort(key=lambda item: not _is_long(item))  # stable: each part keeps its order
