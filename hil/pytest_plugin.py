"""pytest plugin (entry point ``wheelleg``): rig options, fixtures and markers.

Installed with the package, so ``pip install wheelleg-hil`` is enough for a
robot team's own tests to use ``rig_run``.
"""
from __future__ import annotations


def pytest_addoption(parser):
    group = parser.getgroup("wheelleg", "wheelleg-hil rig")
    group.addoption("--can-interface", default="virtual",
                    help="python-can interface the rig runs on (virtual, socketcan, ...)")
    group.addoption("--can-channels", default="vcan0,vcan1",
                    help="CAN1 (wheels) and CAN2 (joints) channels, comma separated")
