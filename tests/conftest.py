"""Shared fixtures: keep this small."""
from __future__ import annotations

import uuid

import can
import pytest


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
