"""DJI RoboMaster C620 ESC driving an M3508 P19 (docs/protocols.md).

The ESC takes its slot of the 0x200 (ESC 1-4) or 0x1FF (ESC 5-8) current
frame, clamps it to +-16384 (+-20 A) and drives the motor; it never answers a
frame. Every 1 ms of simulated time it sends 0x200 + id: rotor angle 0..8191
of the ROTOR (output angle * 3591/187), rotor rpm, torque current and motor
temperature.

Choices where the sources are silent:

* A command frame must be standard-id, data, DLC 8 (the manual's frame);
  anything else is ignored.
* When commands stop, the last current is held forever unless
  ``command_timeout_s`` is set (undocumented; hold is the worst case).
* Back-EMF: the drive torque available at output speed w is
  ``K_EMF * (W_NO_LOAD - |w|)``, capped by the current. K_EMF comes from the
  M3508+C620 speed-torque data (DJI's M3508 manual): rated 3 N m at 469 rpm, no load at
  482 rpm, so 3 N m / 13 rpm = 2.2 N m s/rad; the torque falls to zero at the
  no-load speed. Braking is not limited. The no-load speed is the 24 V one;
  it scales with ``supply_v`` (a DC motor's speed at zero torque is V / ke).
* ``set_supply_voltage``: a sagging battery (plant override) moves the no-load speed.
* ``kt_scale``: the motor's true torque constant over the datasheet's
  0.3 N m/A (a plant override). The feedback reports the current the motor
  carries, so a host that believes 0.3 N m/A misjudges the torque.
* Motor temperature: first order, ``THERMAL_TAU_S`` and ``HEAT_K_PER_A2``
  are assumptions (DJI publishes no thermal data): the rated 10 A settles at
  100 degC. The ESC's optional 125 degC cut-off is not modelled.
* The feedback current is the current the ESC achieves (after the back-EMF
  limit), on the command's scale (community convention).
"""
from __future__ import annotations

import math

import can

from wheelleg.dbc import load_file
from wheelleg.dbc.codec import MessageCodec
from wheelleg.emulators.device import EmulatedDevice, PeriodicSchedule, Shaft, frame, is_data_frame
from wheelleg.emulators.robot import description as D

FEEDBACK_PERIOD_S = 0.001  # 1 kHz default feedback rate (DJI's C620 guide p. 17)
FULL_DLC = 8
RATED_TORQUE_NM = 3.0  # output shaft, max continuous (M3508 manual)
RATED_SPEED_RAD_S = 469 * 2 * math.pi / 60  # output, at rated torque with a C620 (M3508 manual)
BACK_EMF_NM_S_PER_RAD = RATED_TORQUE_NM / (D.M3508_NO_LOAD_SPEED_RAD_S - RATED_SPEED_RAD_S)
THERMAL_TAU_S = 600.0  # s, assumed
HEAT_K_PER_A2 = 0.75  # K/A^2, assumed: 10 A continuous settles 75 K above ambient


class C620(EmulatedDevice):
    """One C620 + M3508 on CAN1 (standard ids)."""

    def __init__(self, esc_id: int = 1, command_timeout_s: float | None = None,
                 ambient_c: float = 25.0, rotor_offset_rad: float = 0.0, shaft: Shaft | None = None,
                 supply_v: float = D.SUPPLY_NOMINAL_V, kt_scale: float = 1.0):
        super().__init__(shaft)
        if not 1 <= esc_id <= 8:
            raise ValueError(f"C620 id must be 1..8, got {esc_id}")
        if command_timeout_s is not None and not command_timeout_s > 0.0:
            raise ValueError(f"command_timeout_s must be > 0 s or None, got {command_timeout_s!r}")
        db = load_file("c620.dbc")
        cmd = db.get_message_by_name("C620_Cmd_1_4" if esc_id <= 4 else "C620_Cmd_5_8")
        self._slot = f"ESC{esc_id}_Current"
        slot_signal = cmd.get_signal_by_name(self._slot)
        self._cmd = MessageCodec(cmd, [slot_signal])
        self._raw_limit = round(slot_signal.maximum / slot_signal.scale)  # 16384
        self._amps_per_raw = slot_signal.scale
        self._fb = MessageCodec.of(db.get_message_by_name(f"C620_Feedback_{esc_id}"))
        # the feedback payload from the angle counts (raw) and the rest rounded to their steps
        self._fb_payload = self._fb.encoder({"RotorAngle": "raw", "RotorSpeed": "rounded", "TorqueCurrent": "rounded",
                                             "MotorTemp": "rounded"})
        self._angle_counts = round(360.0 / self._fb.signals["RotorAngle"].scale)  # 8192 per rotor turn
        self._schedule = PeriodicSchedule(FEEDBACK_PERIOD_S)
        if not (supply_v > 0.0 and kt_scale > 0.0):
            raise ValueError(f"supply_v and kt_scale must be > 0, got {supply_v!r}, {kt_scale!r}")
        self.esc_id = esc_id
        self.torque_constant = D.M3508_TORQUE_CONSTANT_NM_PER_A * kt_scale  # N m/A, true
        self.set_supply_voltage(supply_v)
        self.command_timeout_s = command_timeout_s
        self.rotor_offset_rad = rotor_offset_rad
        self.ambient_c = ambient_c
        self.temperature_c = ambient_c
        self.command_raw = 0
        self.last_command_s: float | None = None

    def set_supply_voltage(self, supply_v: float) -> None:
        """The supply the ESC sees now (V): the no-load speed (rad/s, output) follows it."""
        self.supply_v = supply_v
        self.no_load_speed = D.M3508_NO_LOAD_SPEED_RAD_S * (supply_v / D.SUPPLY_NOMINAL_V)

    def supply_power_w(self, now_s: float) -> float:
        """W drawn from the supply now: shaft power plus the loss of the DC-motor line the back-EMF
        limit draws (torque^2 / BACK_EMF_NM_S_PER_RAD, i.e. I^2 R with R = Kt^2 / K_EMF)."""
        tau = self.output_torque(now_s)
        return tau * self.shaft.speed + tau * tau / BACK_EMF_NM_S_PER_RAD

    # -- frames ------------------------------------------------------------------
    def _handle(self, msg: can.Message, now_s: float) -> list[can.Message]:
        if (msg.arbitration_id != self._cmd.frame_id or msg.is_extended_id or len(msg.data) != FULL_DLC
                or not is_data_frame(msg)):
            return []
        raw = self._cmd.decode_raw(bytes(msg.data))[self._slot]
        self.command_raw = max(-self._raw_limit, min(self._raw_limit, raw))
        self.last_command_s = now_s
        return []

    def _periodic(self, now_s: float) -> list[can.Message]:
        if not self._schedule.due(now_s):
            return []
        return [self.feedback_frame(now_s)]

    def feedback_frame(self, now_s: float) -> can.Message:
        rotor = (self.shaft.angle * D.M3508_GEAR + self.rotor_offset_rad) % (2 * math.pi)
        counts = int(rotor / (2 * math.pi) * self._angle_counts) % self._angle_counts
        rotor_rpm = self.shaft.speed * D.M3508_GEAR * 60.0 / (2 * math.pi)
        payload = self._fb_payload(counts, rotor_rpm, self.output_current(now_s), self.temperature_c)
        return frame(self._fb.frame_id, payload, False, now_s)

    # -- physics -----------------------------------------------------------------
    def commanded_current(self, now_s: float) -> float:
        """A the host asks for now (0 after a command timeout)."""
        if self.command_timeout_s is not None and (
                self.last_command_s is None or now_s - self.last_command_s > self.command_timeout_s):
            return 0.0
        return self.command_raw * self._amps_per_raw

    def output_torque(self, now_s: float) -> float:
        if self.command_timeout_s is None:  # commanded_current, inline: asked ~5 times a millisecond
            tau = self.command_raw * self._amps_per_raw * self.torque_constant
        else:
            tau = self.commanded_current(now_s) * self.torque_constant
        speed = self.shaft.speed
        if tau * speed > 0.0:  # driving: back-EMF leaves less torque near no-load speed
            # max(0, .) and max(-a, min(a, tau)) written out (asked ~5 times a millisecond): the
            # same comparisons in the same order, so the same result for NaN and -0.0
            available = BACK_EMF_NM_S_PER_RAD * (self.no_load_speed - abs(speed))
            if not available > 0.0:
                available = 0.0
            tau = tau if tau < available else available
            tau = tau if tau > -available else -available
        return tau

    def output_current(self, now_s: float) -> float:
        """A the motor carries now (what the feedback reports)."""
        return self.output_torque(now_s) / self.torque_constant

    def advance(self, dt_s: float, now_s: float) -> None:
        if not dt_s > 0.0:
            return
        current = self.output_current(now_s)
        settle = self.ambient_c + HEAT_K_PER_A2 * current * current
        self.temperature_c += (settle - self.temperature_c) * (1.0 - math.exp(-dt_s / THERMAL_TAU_S))
