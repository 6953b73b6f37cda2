"""Run scenarios with the firmware's lockstep library in place of the Python program (a
developer's check of the firmware in closed loop, before the rig's own ``--program``).

    python -m tools.firmware_in_rig SCENARIO [...] [--out DIR] [--python]

The library (wheelleg.hil.firmware_build) stands behind ``controller.can_node.CanNode`` as
its ``controller``: frames in through ``on_frame``, one ``wl_step`` a tick, the heartbeat
built from ``wl_status`` as the rig's lockstep adapter does. ``--python`` runs the Python
program instead, for the speed ratio (the same command, one after the other).
"""
from __future__ import annotations

import argparse
import ctypes
import dataclasses
import sys
import time

import can

from wheelleg.controller import messages
from wheelleg.controller.can_node import CanNode
from wheelleg.controller.node import TickResult
from wheelleg.dbc import CAN1, CAN2
from wheelleg.hil import cli, firmware_build

sys.path.insert(0, "tests")
from firmware_feed import BUS_INDEX, BUS_NAME, PERIOD_US, WlFrame, WlStatus  # noqa: E402


class FirmwareProgram:
    """The lockstep library with Controller's frame-in, tick-out interface."""

    def __init__(self, path):
        lib = self.lib = ctypes.CDLL(str(path))
        lib.wl_step.restype = ctypes.c_int32
        lib.wl_step.argtypes = [ctypes.c_uint64, ctypes.POINTER(WlFrame), ctypes.POINTER(ctypes.c_uint64),
                                ctypes.c_int32, ctypes.POINTER(WlFrame), ctypes.c_int32]
        lib.wl_init(PERIOD_US)
        self.rx, self.times, self.n = (WlFrame * 512)(), (ctypes.c_uint64 * 512)(), 0
        self.tx = (WlFrame * 64)()
        self.step_s = 0.0  # s spent in wl_step
        self.steps = 0

    def prepare(self) -> None:
        pass

    def on_frame(self, msg: can.Message, bus: str, now_s: float):
        if not msg.is_extended_id and msg.arbitration_id == 0x080 and len(msg.data) == 4:
            return int.from_bytes(bytes(msg.data), "little")
        if self.n < len(self.rx) and not msg.is_error_frame and not msg.is_remote_frame:
            f = self.rx[self.n]
            f.id, f.bus, f.extended, f.dlc = msg.arbitration_id, BUS_INDEX[bus], msg.is_extended_id, min(msg.dlc, 8)
            f.data[:] = bytes(msg.data).ljust(8, b"\0")[:8]
            self.times[self.n] = round(now_s * 1e6)
            self.n += 1
        return None

    def tick(self, tick: int, now_s: float) -> TickResult:
        start = time.perf_counter()
        count = self.lib.wl_step(round(now_s * 1e6), self.rx, self.times, self.n, self.tx, len(self.tx))
        self.step_s += time.perf_counter() - start
        self.steps += 1
        self.n = 0
        result = TickResult()
        for f in self.tx[:count]:
            result.frames[BUS_NAME[f.bus]].append(can.Message(arbitration_id=f.id, is_extended_id=bool(f.extended),
                                                              data=bytes(f.data[:f.dlc]), timestamp=now_s))
        status = WlStatus()
        self.lib.wl_status(ctypes.byref(status))
        hb = messages.heartbeat(tick, status.mode, 0, status.offline_mask, bin(status.offline_mask).count("1"),
                                motors_enabled=status.mode in (2, 3, 4, 5, 6), off_ground=status.mode == 6,
                                fallen=status.mode == 7, fault_latched=False, bad_frames=0, t_s=now_s)
        result.frames[CAN1].append(hb)
        result.frames[CAN2].append(hb)
        return result

    def shutdown_frames(self, now_s: float) -> dict:
        return {CAN1: [], CAN2: []}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("scenarios", nargs="+")
    parser.add_argument("--out", default="/tmp/fw_rig")
    parser.add_argument("--python", action="store_true")
    args = parser.parse_args(argv)
    programs = []
    if not args.python:
        path = firmware_build.build("lib")

        def build_controller(buses, sync, period_s):
            program = FirmwareProgram(path)
            programs.append(program)
            return CanNode(buses[CAN1], buses[CAN2], program, sync=sync, period_s=period_s)
        from wheelleg.hil import robots  # noqa: PLC0415
        # robots.get keeps each loaded robot: the default one swapped for one with the library as
        # its controller; no debug record (the library's is not the TickResult's)
        robot = robots.get()
        robots._LOADED[robot.name] = dataclasses.replace(robot, build_controller=build_controller, debug_schema=None)
    status = 0
    for name in args.scenarios:
        start = time.perf_counter()
        code = cli.main(["run", name, "--out", args.out])
        wall = time.perf_counter() - start
        line = f"{name}: exit {code}, {wall:.1f} s wall"
        if programs:
            p = programs[-1]
            line += f", firmware {1e6 * p.step_s / max(p.steps, 1):.1f} us per wl_step ({p.steps} ticks)"
        print(line, flush=True)
        status = status or code
    return status


if __name__ == "__main__":
    sys.exit(main())
