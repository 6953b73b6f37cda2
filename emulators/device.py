"""What every emulated CAN device shares: its shaft and its API.

A device answers frames (``handle``), emits its periodic frames
(``periodic``) and tells the physics the torque it applies to its output
shaft (``output_torque``). In physics mode the plant writes ``shaft.angle``
and ``shaft.speed`` after each physics step and calls ``advance``; alone (a
driver talking to one emulated device) ``step_alone`` integrates the shaft
as a simple inertia with viscous and Coulomb friction.

Times are simulated seconds (``now_s``); every frame a device emits carries
``timestamp = now_s``.

Devices encode and decode their frames with ``wheelleg.dbc.codec`` (compiled
once from the DBC): they sit on the rig's hot path (~20 frames per 2 ms tick
at >= 10x real time), where cantools' ``Message.encode`` costs ~12 us a frame.
"""
from __future__ import annotations

import abc
import logging
import math
from dataclasses import dataclass

import can

log = logging.getLogger(__name__)

MAX_SUBSTEP_S = 0.0005  # s, longest shaft integration step in step_alone (stiff Kp/Kd gains)


@dataclass
class Shaft:
    """The output shaft a device drives.

    Alone it is an inertia with viscous and Coulomb friction driven by the
    motor and ``load_torque``; with physics, the plant overwrites ``angle``
    and ``speed`` and the friction parameters are unused.
    """

    inertia: float = 0.005  # kg m^2, output side
    viscous: float = 0.002  # N m s/rad
    coulomb: float = 0.02  # N m, dry friction magnitude
    angle: float = 0.0  # rad, output side, multi-turn, continuous
    speed: float = 0.0  # rad/s
    load_torque: float = 0.0  # N m, external torque on the shaft (alone only)

    def step_alone(self, motor_torque_nm: float, dt_s: float) -> None:
        """Semi-implicit Euler step of ``dt_s`` seconds under ``motor_torque_nm``.

        Coulomb friction removes at most the speed it can in one step, so a
        shaft at rest with a drive below ``coulomb`` stays at rest instead of
        chattering around zero.
        """
        drive = motor_torque_nm + self.load_torque - self.viscous * self.speed
        speed = self.speed + drive * dt_s / self.inertia
        friction_dv = self.coulomb * dt_s / self.inertia
        if abs(speed) <= friction_dv and abs(motor_torque_nm + self.load_torque) <= self.coulomb:
            speed = 0.0
        elif speed != 0.0:
            speed -= math.copysign(min(friction_dv, abs(speed)), speed)
        self.speed = speed
        self.angle += speed * dt_s


class EmulatedDevice(abc.ABC):
    """One CAN node of the robot, driven only through frames.

    Subclasses implement ``_handle`` (which may assume nothing about the
    frame), ``output_torque`` and, if they have internal dynamics,
    ``advance``. ``handle`` never raises: an unexpected exception is a bug in
    the emulator, counted in ``internal_errors`` (the fuzz test asserts it
    stays 0) and answered with silence.

    Fault policy (hil/run/faults.py sets it; one place for every device):
    ``silent`` sends nothing (unplugged, dead); ``frozen`` repeats the last
    frame of each kind (``_frame_key``) with a fresh time stamp instead of new
    data (a hung firmware whose CAN peripheral still transmits); ``deaf``
    ignores every received frame but keeps sending (a C620 then holds its
    last current). Silent wins over frozen.
    """

    def __init__(self, shaft: Shaft | None = None):
        self.shaft = shaft if shaft is not None else Shaft()
        self.internal_errors = 0
        self.silent = False
        self.frozen = False
        self.deaf = False
        self._last_out: dict = {}  # _frame_key -> last frame sent, for ``frozen``

    def handle(self, msg: can.Message, now_s: float) -> list[can.Message]:
        """Reply frames to one received frame (empty: silence, as the real device)."""
        if self.deaf:
            return []
        try:
            replies = self._handle(msg, now_s)
        except Exception:  # noqa: BLE001 - a device never crashes on input
            self.internal_errors += 1
            if self.internal_errors == 1:
                log.exception("%s: internal error on frame %s", type(self).__name__, msg)
            return []
        return self._emit(replies, now_s) if replies else replies  # mostly none: not addressed to it

    def _emit(self, frames: list[can.Message], now_s: float) -> list[can.Message]:
        """Apply the fault policy to frames about to be sent."""
        if self.silent:
            return []
        if self.frozen:
            return [_restamped(self._last_out.get(self._frame_key(f), f), now_s) for f in frames]
        for f in frames:
            self._last_out[self._frame_key(f)] = f
        return frames

    # False for a device that only talks (its ``_handle`` answers nothing and changes
    # nothing): its node does not hand it the frames it receives.
    listens = True

    # The node's acceptance filter, as a CAN controller's: None hands the device every
    # frame; (extended, field, attribute) only the frames whose ``is_extended_id`` is
    # ``extended`` and whose identifier's ``field(arbitration_id)`` equals the device's
    # ``attribute`` (read at each frame, so it follows an id change). Only for frames the
    # device's ``_handle`` turns away first thing, unanswered and unchanged by them: the
    # node then skips the call (a CyberGear: 4 of every 5 frames on its bus are for another motor).
    rx_filter: tuple | None = None

    def _frame_key(self, msg: can.Message):
        """What makes two frames "the same kind" for ``frozen`` (the id, by default)."""
        return msg.arbitration_id

    @abc.abstractmethod
    def _handle(self, msg: can.Message, now_s: float) -> list[can.Message]:
        """Device-specific reply logic (see ``handle``)."""

    def periodic(self, now_s: float) -> list[can.Message]:
        """Frames due by ``now_s`` that the device sends on its own, after the fault policy."""
        frames = self._periodic(now_s)
        return self._emit(frames, now_s) if frames else frames  # mostly none: the policy has nothing to do

    def _periodic(self, now_s: float) -> list[can.Message]:
        """Device-specific periodic frames (none by default)."""
        return []

    @abc.abstractmethod
    def output_torque(self, now_s: float) -> float:
        """N m the motor applies to its output shaft now, after all limits, faults and mode."""

    def advance(self, dt_s: float, now_s: float) -> None:
        """Advance internal models (temperature, integrators) over ``dt_s`` ending at ``now_s``."""

    def step_alone(self, dt_s: float, now_s: float) -> None:
        """Advance shaft and internal models over ``dt_s`` ending at ``now_s``, without physics.

        Sub-steps of at most ``MAX_SUBSTEP_S`` keep stiff gains (Kp 500 on a
        small inertia) stable; the torque is held over each sub-step as the
        physics holds it over a physics step.
        """
        if not dt_s > 0.0:
            return
        n = max(1, math.ceil(dt_s / MAX_SUBSTEP_S))
        h = dt_s / n
        start = now_s - dt_s
        for k in range(n):
            t = start + k * h
            self.shaft.step_alone(self.output_torque(t), h)
            self.advance(h, t + h)


class PeriodicSchedule:
    """Send slots at whole multiples of ``period_s`` of simulated time.

    ``due(now_s)`` is true once for the latest slot reached; slots missed
    because nobody called in time are skipped, not replayed (they would
    carry the same state).
    """

    def __init__(self, period_s: float):
        if not period_s > 0.0:
            raise ValueError(f"period must be > 0 s, got {period_s!r}")
        self.period_s = period_s
        self._next_slot = 0

    def due(self, now_s: float) -> bool:
        slots = now_s / self.period_s + 1e-6  # 1e-6 of a period: float grid error
        if slots < self._next_slot:  # floor(slots) < next slot, without the floor: asked ~3 times a slot
            return False
        self._next_slot = math.floor(slots) + 1
        return True


def frame(arbitration_id: int, data: bytes, extended: bool, now_s: float) -> can.Message:
    """A transmitted frame stamped with simulated time (is_rx False)."""
    # python-can's parameters by position (timestamp, arbitration_id, is_extended_id, is_remote_frame,
    # is_error_frame, channel, dlc, data, is_fd, is_rx): a third cheaper than by keyword
    return can.Message(now_s, arbitration_id, extended, False, False, None, None, data, False, False)


def _restamped(msg: can.Message, now_s: float) -> can.Message:
    """A copy of ``msg`` sent again at ``now_s`` (same id and data)."""
    return frame(msg.arbitration_id, bytes(msg.data), msg.is_extended_id, now_s)


def is_data_frame(msg: can.Message) -> bool:
    """False for remote, error and CAN FD frames, which no emulated device acts on."""
    return not (msg.is_remote_frame or msg.is_error_frame or msg.is_fd)
