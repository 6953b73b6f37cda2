"""The same recorded inputs, tick by tick, to the firmware's lockstep library (ctypes, the ABI
of firmware/include/wl_lockstep.h) and to the Python program (controller/node.py Controller),
and their commands side by side (tests/test_firmware_build.py)."""
from __future__ import annotations

import ctypes
from dataclasses import dataclass, field

import can

from wheelleg.controller import constants as C
from wheelleg.controller import params as P
from wheelleg.controller.node import Controller
from wheelleg.dbc import CAN1, CAN2
from wheelleg.dbc import cybergear as cg
from wheelleg.hil.program.library import WlFrame, WlStatus  # the ABI's layouts, written once
from wheelleg.hil.record import sources

BUS_INDEX = {CAN1: 0, CAN2: 1}
BUS_NAME = {0: CAN1, 1: CAN2}
PERIOD_US = round(P.CONTROL_PERIOD * 1e6)




@dataclass
class Tick:
    """One control period's inputs: the frames each bus delivered before its SYNC (bus, message, t in us)."""

    number: int
    frames: list = field(default_factory=list)

    @property
    def now_us(self) -> int:
        return self.number * PERIOD_US


def recorded_ticks(path) -> list[Tick]:
    """A recording's inputs to the controller, per tick, as the lockstep node delivers them
    (controller/can_node.py): each frame stamped (its bus's last SYNC + 1) periods, a tick
    when both buses have had the same SYNC. The controller's own frames are left out."""
    rec = sources.open_recording(path)
    last_sync = {CAN1: None, CAN2: None}
    ticks, pending, last_tick = [], [], None
    for frame in rec.frames:
        if frame.bus not in BUS_INDEX or frame.is_error or sources.sent_by_controller(frame):
            continue
        if sources.is_sync(frame):
            last_sync[frame.bus] = sources.sync_tick(frame)
            tick = last_sync[CAN1]
            if tick is not None and tick == last_sync[CAN2] and tick != last_tick:
                ticks.append(Tick(tick, pending))
                pending, last_tick = [], tick
            continue
        stamp = last_sync[frame.bus]
        t_us = 0 if stamp is None else (stamp + 1) * PERIOD_US
        msg = can.Message(arbitration_id=frame.arbitration_id, is_extended_id=frame.is_extended,
                          data=frame.data, dlc=frame.dlc)
        pending.append((frame.bus, msg, t_us))
    return ticks


def rx_arrays(tick: Tick) -> tuple:
    """(rx, rx_time_us, n): ``tick``'s received frames as the ABI's ``wl_frame_t`` array and times (us)."""
    n = len(tick.frames)
    rx, times = (WlFrame * max(n, 1))(), (ctypes.c_uint64 * max(n, 1))()
    for i, (bus, msg, t_us) in enumerate(tick.frames):
        rx[i].id, rx[i].bus, rx[i].extended, rx[i].dlc = msg.arbitration_id, BUS_INDEX[bus], msg.is_extended_id, msg.dlc
        rx[i].data[:len(msg.data)] = bytes(msg.data)
        times[i] = t_us
    return rx, times, n


class Firmware:
    """The lockstep library through ctypes."""

    def __init__(self, path):
        lib = self.lib = ctypes.CDLL(str(path))
        lib.wl_step.restype = ctypes.c_int32
        lib.wl_step.argtypes = [ctypes.c_uint64, ctypes.POINTER(WlFrame), ctypes.POINTER(ctypes.c_uint64),
                                ctypes.c_int32, ctypes.POINTER(WlFrame), ctypes.c_int32]
        lib.wl_build_id.restype = ctypes.c_char_p
        lib.wl_debug_names.restype = ctypes.c_char_p
        lib.wl_debug.argtypes = [ctypes.POINTER(ctypes.c_float), ctypes.c_int32]
        lib.wl_init(PERIOD_US)
        self.tx = (WlFrame * 64)()

    def step(self, tick: Tick) -> list[tuple]:
        rx, times, n = rx_arrays(tick)
        count = self.lib.wl_step(tick.now_us, rx, times, n, self.tx, len(self.tx))
        return [(BUS_NAME[f.bus], f.id, bool(f.extended), bytes(f.data[:f.dlc])) for f in self.tx[:count]]

    def mode(self) -> int:
        status = WlStatus()
        self.lib.wl_status(ctypes.byref(status))
        return status.mode


def python_step(controller: Controller, tick: Tick) -> tuple[int, list[tuple]]:
    """The Python program's tick on the same inputs: (mode, frames without the heartbeat)."""
    for bus, msg, t_us in tick.frames:
        controller.on_frame(msg, bus, t_us * 1e-6)
    result = controller.tick(tick.number, tick.number * P.CONTROL_PERIOD)
    frames = [(bus, m.arbitration_id, m.is_extended_id, bytes(m.data)) for bus, msgs in result.frames.items()
              for m in msgs if m.arbitration_id != sources.HEARTBEAT.frame_id]
    return int(result.mode), frames


_C620 = sources.DBS[CAN1].get_message_by_name("C620_Cmd_1_4")


def commands(frames) -> dict:
    """The torque commands among ``frames``: 'hip<id>' N m (type-1 ids), 'esc<n>' A (0x200)."""
    out = {}
    for bus, arbitration_id, extended, data in frames:
        if extended and cg.comm_type(arbitration_id) == cg.T_MOTION:
            out[f"hip{cg.target(arbitration_id)}"] = cg.motion_torque(arbitration_id)
        elif not extended and arbitration_id == _C620.frame_id:
            values = _C620.decode(data)
            for w in C.WHEELS:
                out[f"esc{w.esc_id}"] = values[f"ESC{w.esc_id}_Current"]
    return out


FULL_SCALE = {"hip": C.CG_TORQUE_LIMIT, "esc": C.C620_CURRENT_LIMIT}  # N m, A
