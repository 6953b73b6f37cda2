"""DJI RoboMaster C610/M2006 and GM6020 on CAN, frame for frame (docs/protocols.md, DJI drives).

Both are the C620's kind (emulators/c620.py): they never answer a frame; the
host's group frame carries a signed big-endian int16 slot per device; every
1 ms of simulated time each device sends its feedback frame (rotor angle
0..8191, rotor rpm, torque current and, for the GM6020, the temperature).

* C610 + M2006 P36: current slots in 0x200 (ESC 1-4) and 0x1FF (ESC 5-8),
  -10000..10000 <-> -10..10 A; feedback 0x200 + id; gearbox 36:1; the
  C610 sends no temperature (bytes 6 and 7 zero).
* GM6020 (direct drive, ids 1-7): voltage slots in 0x1FF (1-4) and 0x2FF
  (5-7), -25000..25000 of the supply's full duty; current slots (firmware
  with current mode) in 0x1FE and 0x2FE, -16384..16384 <-> -3..3 A;
  feedback 0x204 + id. The last command frame received, voltage or current,
  is the one obeyed.

Choices where the sources are silent (docs/protocols.md) are those of the
C620: a command must be standard-id, data, DLC 8; the last command is held
unless ``command_timeout_s`` is set; braking is not limited; the temperature
is first order (assumed constants, below). The motors are DC-motor lines:
the drive current is ``(V - ke w) / R`` in voltage mode, and in current mode
the commanded current within what the supply can push against the back-EMF,
``(V_supply - ke |w|) / R`` when driving.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import can

from wheelleg.dbc import load_file
from wheelleg.dbc.codec import MessageCodec
from wheelleg.emulators.device import EmulatedDevice, PeriodicSchedule, Shaft, frame, is_data_frame

FEEDBACK_PERIOD_S = 0.001  # 1 kHz feedback (DJI's C610 and GM6020 guides)
FULL_DLC = 8
NOMINAL_SUPPLY_V = 24.0
CURRENT, VOLTAGE = "current", "voltage"


@dataclass(frozen=True)
class DjiModel:
    """One DJI drive's frames and motor line (output side, SI units)."""

    name: str
    dbc: str
    ids: range  # valid device ids
    commands: tuple  # (message name, ids it carries, slot name pattern with {id}, CURRENT | VOLTAGE)
    feedback: str  # feedback message name pattern with {id}
    gear: float  # rotor turns per output turn
    torque_constant: float  # N m/A at the output
    back_emf: float  # V s/rad at the output (ke)
    resistance_ohm: float  # phase-to-phase, the DC-motor line's R
    current_limit_a: float
    thermal_tau_s: float
    heat_k_per_a2: float


M2006 = DjiModel(
    name="c610", dbc="c610.dbc", ids=range(1, 9),
    commands=(("C610_Cmd_1_4", range(1, 5), "ESC{id}_Current", CURRENT),
              ("C610_Cmd_5_8", range(5, 9), "ESC{id}_Current", CURRENT)),
    feedback="C610_Feedback_{id}", gear=36.0,
    # M2006 P36 manual: 0.18 N m/A at the output; no-load 500 rpm at the output (24 V) gives
    # ke = 24 V / 52.4 rad/s = 0.458 V s/rad; R from the rated point 1 N m (5.56 A) at 416 rpm ⚠ assumed
    torque_constant=0.18, back_emf=24.0 / (500 * 2 * math.pi / 60), resistance_ohm=0.72,
    current_limit_a=10.0, thermal_tau_s=300.0, heat_k_per_a2=2.0)  # ⚠ thermal assumed: 3 A rated -> +18 K

GM6020_MODEL = DjiModel(
    name="gm6020", dbc="gm6020.dbc", ids=range(1, 8),
    commands=(("GM6020_Voltage_1_4", range(1, 5), "Motor{id}_Voltage", VOLTAGE),
              ("GM6020_Voltage_5_7", range(5, 8), "Motor{id}_Voltage", VOLTAGE),
              ("GM6020_Current_1_4", range(1, 5), "Motor{id}_Current", CURRENT),
              ("GM6020_Current_5_7", range(5, 8), "Motor{id}_Current", CURRENT)),
    feedback="GM6020_Feedback_{id}", gear=1.0,
    # GM6020 guide: 741 mN m/A, no-load 320 rpm at 24 V (ke = 0.716 V s/rad), 1.8 ohm ⚠ (phase to phase)
    torque_constant=0.741, back_emf=24.0 / (320 * 2 * math.pi / 60), resistance_ohm=1.8,
    current_limit_a=3.0, thermal_tau_s=600.0, heat_k_per_a2=8.0)  # ⚠ thermal assumed: 1.6 A -> +20 K


class DjiMotor(EmulatedDevice):
    """One DJI drive (``model``) with id ``esc_id`` on a standard-id bus."""

    def __init__(self, model: DjiModel, esc_id: int = 1, command_timeout_s: float | None = None,
                 ambient_c: float = 25.0, shaft: Shaft | None = None, supply_v: float = NOMINAL_SUPPLY_V,
                 kt_scale: float = 1.0):
        super().__init__(shaft)
        if esc_id not in model.ids:
            raise ValueError(f"{model.name} id must be {model.ids.start}..{model.ids.stop - 1}, got {esc_id}")
        if command_timeout_s is not None and not command_timeout_s > 0.0:
            raise ValueError(f"command_timeout_s must be > 0 s or None, got {command_timeout_s!r}")
        if not (supply_v > 0.0 and kt_scale > 0.0):
            raise ValueError(f"supply_v and kt_scale must be > 0, got {supply_v!r}, {kt_scale!r}")
        db = load_file(model.dbc)
        self._commands = {}  # frame id -> (codec of this device's slot, slot name, unit per raw, raw limit, kind)
        for name, ids, slot, kind in model.commands:
            if esc_id in ids:
                msg = db.get_message_by_name(name)
                signal = msg.get_signal_by_name(slot.format(id=esc_id))
                self._commands[msg.frame_id] = (MessageCodec(msg, [signal]), signal.name, signal.scale,
                                                round(signal.maximum / signal.scale), kind)
        self._fb = MessageCodec.of(db.get_message_by_name(model.feedback.format(id=esc_id)))
        self._angle_counts = round(360.0 / self._fb.signals["RotorAngle"].scale)  # 8192 per rotor turn
        self._schedule = PeriodicSchedule(FEEDBACK_PERIOD_S)
        self.model = model
        self.esc_id = esc_id
        self.command_timeout_s = command_timeout_s
        self.supply_v = supply_v
        self.kt_scale = kt_scale  # the motor's true torque constant over the datasheet's (a plant override)
        self.ambient_c = ambient_c
        self.temperature_c = ambient_c
        self.command = 0.0  # A (current mode) or the fraction of full duty, -1..1 (voltage mode)
        self.command_kind = CURRENT
        self.last_command_s: float | None = None

    def set_supply_voltage(self, supply_v: float) -> None:
        """The supply the drive sees now (V): voltage commands and the back-EMF limit follow it."""
        self.supply_v = supply_v

    def supply_power_w(self, now_s: float) -> float:
        """W drawn from the supply now: shaft power plus the windings' I^2 R."""
        current = self.motor_current(now_s)
        return self.output_torque(now_s) * self.shaft.speed + current * current * self.model.resistance_ohm

    # -- frames ------------------------------------------------------------------
    def _handle(self, msg: can.Message, now_s: float) -> list[can.Message]:
        entry = self._commands.get(msg.arbitration_id)
        if entry is None or msg.is_extended_id or len(msg.data) != FULL_DLC or not is_data_frame(msg):
            return []
        codec, slot, unit, limit, kind = entry
        raw = max(-limit, min(limit, codec.decode_raw(bytes(msg.data))[slot]))
        self.command = raw * unit if kind == CURRENT else raw / limit
        self.command_kind = kind
        self.last_command_s = now_s
        return []

    def _periodic(self, now_s: float) -> list[can.Message]:
        return [self.feedback_frame(now_s)] if self._schedule.due(now_s) else []

    def feedback_frame(self, now_s: float) -> can.Message:
        rotor = (self.shaft.angle * self.model.gear) % (2 * math.pi)
        raw = {"RotorAngle": int(rotor / (2 * math.pi) * self._angle_counts) % self._angle_counts,
               "RotorSpeed": self._fb.signals["RotorSpeed"].rounded(
                   self.shaft.speed * self.model.gear * 60.0 / (2 * math.pi)),
               "TorqueCurrent": self._fb.signals["TorqueCurrent"].rounded(self.motor_current(now_s))}
        if "MotorTemp" in self._fb.signals:
            raw["MotorTemp"] = self._fb.signals["MotorTemp"].rounded(self.temperature_c)
        return frame(self._fb.frame_id, self._fb.encode_raw(raw), False, now_s)

    # -- physics -----------------------------------------------------------------
    def _timed_out(self, now_s: float) -> bool:
        return self.command_timeout_s is not None and (
            self.last_command_s is None or now_s - self.last_command_s > self.command_timeout_s)

    def motor_current(self, now_s: float) -> float:
        """A in the windings now: the command through the DC-motor line (what the feedback reports)."""
        if self._timed_out(now_s):
            return 0.0
        m, speed = self.model, self.shaft.speed
        emf = m.back_emf * speed
        if self.command_kind == VOLTAGE:
            current = (self.command * self.supply_v - emf) / m.resistance_ohm
        else:
            current = self.command
            if current * speed > 0.0:  # driving: the supply cannot push more against the back-EMF
                available = max(0.0, (self.supply_v - abs(emf)) / m.resistance_ohm)
                current = max(-available, min(available, current))
        return max(-m.current_limit_a, min(m.current_limit_a, current))

    def output_torque(self, now_s: float) -> float:
        return self.motor_current(now_s) * self.model.torque_constant * self.kt_scale

    def advance(self, dt_s: float, now_s: float) -> None:
        if not dt_s > 0.0:
            return
        current = self.motor_current(now_s)
        settle = self.ambient_c + self.model.heat_k_per_a2 * current * current
        self.temperature_c += (settle - self.temperature_c) * (1.0 - math.exp(-dt_s / self.model.thermal_tau_s))


def C610(esc_id: int = 1, **kwargs) -> DjiMotor:
    """A C610 ESC driving an M2006 P36."""
    return DjiMotor(M2006, esc_id, **kwargs)


def GM6020(motor_id: int = 1, **kwargs) -> DjiMotor:
    """A GM6020 with its built-in ESC."""
    return DjiMotor(GM6020_MODEL, motor_id, **kwargs)
