"""Xiaomi CyberGear micro-motor, frame for frame (docs/protocols.md).

Reply rules (docs/protocols.md, how the emulated CyberGear answers): every accepted host->motor frame of types 0, 1, 2 (a
poll), 3, 4, 5, 6, 7, 9, 17, 18, 20 (brake), 21 and 22 gets exactly one reply, a
type-19 table request the whole table, a type-8 config write none (the stored
table: ``cybergear_config``); the
motor sends nothing on its own but the type-5 calibration result. A sender
(bits 15..8) in 0..127 other than ``host_id`` is another motor: never answered;
the echo of a frame the motor sent to its own id is dropped (no reply storms). Types 0/7/22 answer with a type-0 device-id frame to
0xFE, 17 with a type-17 frame, 21 with a type-21 fault/warning frame and
everything else with a type-2 feedback frame. Replies go to the host id in
bits 15..8 of the request; type 1 carries none and is answered to the last
host seen (initially 0x00, CAN_MASTER's example value).

Choices where the sources are silent (docs/protocols.md), made once here:

* DLC: types whose payload the motor reads (1, 6, 17, 18, 22) need DLC 8 (a
  stop of any length stops),
  otherwise silence; types whose payload it ignores (0, 2, 3, 7, 21) accept
  any DLC (the debugger sends type 0 with DLC 1).
* Types 10-16 and 23-31, remote/error/FD frames,
  standard ids and frames for other targets: silence.
* Type 17 of an index outside 0x7005-0x7020's table: silence (the manual
  does not say; a driver then times out, which it must handle anyway).
* Type 18 always answers type 2. Unknown indices and read-only ones
  (0x7019-0x701C) are ignored; run_mode is only taken in reset mode (the
  manual's precaution) and only 0..3; NaN/inf floats are ignored; finite
  values are clamped to the manual's range (the DBC signal's range).
* A latched fault cuts the torque and drops the motor to reset mode; only
  type 4 with byte0 = 1 clears it; type 3 then enables again. A latched
  fault makes type 3 answer in mode 0.
* Type 6 zeroes only when byte0 = 1 (the manual's payload); it answers
  type 2 either way.
* Type 7 to a new id above 127 (CAN_ID's range) keeps the old id and
  answers type 0 from it.
* Type 1 while in reset mode, or while run_mode is not 0, answers type 2
  and changes no torque.

Model: the output torque per run mode (0 motion, 1 position, 2 speed,
3 current) is limited to +-limit_torque, then +-12 N m, then by a back-EMF
line so that the motor cannot push the shaft beyond 30 rad/s; the winding
temperature follows a first-order model (``THERMAL_TAU_S``) and latches the
over-temperature fault at 80 degC. The back-EMF line's speed scales with the
supply (``vbus_v``, 24 V nominal). ``kt_scale`` is the shaft's true torque
over the torque the firmware means to make (its torque constant wrong, a plant
override): the shaft gets ``kt_scale`` times it, the feedback reports what
the firmware believes it makes. ``zero_offset_rad`` is where the zero was set by
hand (a plant override): the motor reports the shaft angle minus it until a type 6
moves the zero. ``set_supply_voltage`` follows a sagging battery.
"""
from __future__ import annotations

import math
from collections import deque

import can

from wheelleg.dbc import CYBERGEAR_FILES
from wheelleg.dbc import cybergear as cg
from wheelleg.emulators.cybergear_config import StoredTable
from wheelleg.emulators.cybergear_family import Layouts, MotorLine
from wheelleg.emulators.device import EmulatedDevice, Shaft, frame, is_data_frame
from wheelleg.emulators.robot import description as D

MODE_RESET, MODE_CALI, MODE_RUN, MODE_BRAKE = 0, 1, 2, 3
RUN_OPERATION, RUN_POSITION, RUN_SPEED, RUN_CURRENT, RUN_ZERO, RUN_QUICK_MOVE = 0, 1, 2, 3, 4, 7
RUN_MODES = (0, 1, 2, 3, 4, 7)  # 4 zero return and 7 quick move: public driver and debugger traffic
SPEED_LOOP_MODES = (RUN_POSITION, RUN_SPEED, RUN_ZERO, RUN_QUICK_MOVE)  # speed loop under the current loop
# Encoder calibration (type 5): the public driver says "a few seconds" and waits up to 30 s;
# the emulator takes CALIBRATION_S and reports ELEC_OFFSET_RAD (any value in -pi..pi would do).
CALIBRATION_S = 2.0
ELEC_OFFSET_RAD = 0.4537
MAX_MOTOR_ID = cg.MAX_MOTOR_ID  # parameter CAN_ID 0x200A range
ECHO_MEMORY = 160  # own frames remembered to recognise their echo (docs/protocols.md, reply storms): a whole
# type-19 table answer (114 frames) and more, since a table request is answered whatever its payload
CURRENT_LIMIT_A = 23.0  # peak phase current; iq_ref / limit_cur range
FULL_DLC = 8

# Back-EMF: the drive torque available at speed v is K_EMF * (V_MAX - |v|),
# capped at 12 N m. K_EMF = Kt * ke / R with Kt 0.87 N m/A, R 0.45 ohm and
# ke = 0.055 Vrms/rpm (output rpm) * sqrt(2) * 60 / (2 pi) = 0.743 V s/rad
# (the manual's data): 1.44 N m s/rad. V_MAX is the protocol's 30 rad/s (no-load ~31): full
# torque up to ~21.7 rad/s, none beyond 30 rad/s, so the motor alone cannot
# drive the shaft past the range of its velocity field. Braking is not limited.
BACK_EMF_NM_S_PER_RAD = 1.44
SPEED_LIMIT_RAD_S = D.CG_SPEED_LIMIT_RAD_S  # at the nominal supply

# Winding temperature, first order: dT/dt = (T_amb + HEAT * I^2 - T) / TAU.
# Fitted to the overload table (the manual's, 25 degC ambient) so that the fault at
# 80 degC trips at the table's times: 12 N m for 28 s and 6 N m for 700 s give
# two equations 55 K = a tau_i^2 (1 - exp(-t_i / TAU)) (a in K/(N m)^2);
# solving: TAU = 97.4 s, a = 1.529 K/(N m)^2, i.e. HEAT = a Kt^2 = 1.157 K/A^2.
# Then 4 N m (rated, continuous) settles at 49 degC and never trips; 10 N m
# trips in 43 s and 8 N m in 80 s, earlier than the table's 60 s and 160 s
# (the table's limit is the 120 degC winding, a first-order model cannot
# match all five points; erring early is the safe side for a test rig).
THERMAL_TAU_S = 97.4
HEAT_K_PER_A2 = 1.157
# Speed-loop integral: spd_ki is taken as amperes per (rad/s) of error per
# loop tick at an assumed 1 kHz speed loop (the manual gives no unit).
SPEED_LOOP_HZ = 1000.0

DEFAULT_PARAMS = {  # runtime table defaults (the manual's tables); ⚠ limit_spd assumed 2 rad/s
    "run_mode": 0, "iq_ref": 0.0, "spd_ref": 0.0, "limit_torque": 12.0, "cur_kp": 0.125,
    "cur_ki": 0.0158, "cur_filt_gain": 0.1, "loc_ref": 0.0, "limit_spd": 2.0,
    "limit_cur": CURRENT_LIMIT_A, "loc_kp": 30.0, "spd_kp": 1.0, "spd_ki": 0.002,
}
READ_ONLY = frozenset({"mechPos", "iqf", "mechVel", "VBUS"})  # 0x7019-0x701C
# id fault bit -> type-21 fault word bit (docs/protocols.md, types 2 and 21); the encoder faults have no word bit
FAULT_WORD = {"FaultOverTemp": "FaultOverTemp", "FaultUnderVoltage": "FaultUnderVoltage",
              "FaultOverCurrent": "FaultPhaseAOverCurrent", "FaultNotCalibrated": "FaultNotCalibrated"}
BAUD_CODES = (1, 2, 3, 4)  # type 22: 1M, 500k, 250k, 125k


CYBERGEAR_LINE = MotorLine(D.CG_TORQUE_LIMIT_NM, SPEED_LIMIT_RAD_S, BACK_EMF_NM_S_PER_RAD,
                           D.CG_TORQUE_CONSTANT_NM_PER_A, CURRENT_LIMIT_A, THERMAL_TAU_S, HEAT_K_PER_A2,
                           D.CG_OVER_TEMP_C, D.CG_WARN_TEMP_C, D.SUPPLY_NOMINAL_V, D.CG_LINE_RESISTANCE_OHM)


def _clamp(x: float, lo: float, hi: float) -> float:
    return lo if x < lo else hi if x > hi else x


class CyberGear(EmulatedDevice):
    """One CyberGear on a CAN bus (29-bit ids); see the module docstring for the rules.

    A member of the protocol family (emulators/robstride.py) changes the class
    attributes below, ``_layouts``, ``_handler_table`` and ``_id_torque``.
    """

    LINE = CYBERGEAR_LINE
    UID_BASE = 0x4347_0000_0000_0000  # "CG": the default MCU UID is this | motor id
    DEFAULT_PARAMS = DEFAULT_PARAMS
    RUN_MODES = RUN_MODES
    SPEED_LOOP_MODES = SPEED_LOOP_MODES
    READ_ONLY = READ_ONLY

    def __init__(self, motor_id: int = 0x7F, position_range: str = "12.5", uid: int | None = None,
                 ambient_c: float = 25.0, host_id: int = 0x00, vbus_v: float = D.SUPPLY_NOMINAL_V,
                 shaft: Shaft | None = None, kt_scale: float = 1.0, zero_offset_rad: float = 0.0):
        super().__init__(shaft)
        if not 0 <= motor_id <= MAX_MOTOR_ID:
            raise ValueError(f"CyberGear motor id must be 0..{MAX_MOTOR_ID}, got {motor_id}")
        self._lay = self._layouts(position_range)
        self.position_range = position_range
        self.motor_id = motor_id
        if uid is not None and not 0 <= uid <= 0xFFFF_FFFF_FFFF_FFFF:
            raise ValueError(f"CyberGear uid must fit the 64-bit MCU id of the type-0 reply, got {uid:#x}")
        if not 0 <= host_id <= 0xFF:
            raise ValueError(f"CyberGear host id must be 0..255, got {host_id}")
        self.uid = (self.UID_BASE | motor_id) if uid is None else uid
        self.ambient_c = ambient_c
        self.temperature_c = ambient_c
        if not (vbus_v > 0.0 and kt_scale > 0.0):
            raise ValueError(f"vbus_v and kt_scale must be > 0, got {vbus_v!r}, {kt_scale!r}")
        self.kt_scale = kt_scale
        self.set_supply_voltage(vbus_v)
        # LINE's two numbers firmware_torque reads ~10 times a control period, one attribute each
        self._peak_nm, self._back_emf = self.LINE.torque_limit_nm, self.LINE.back_emf_nm_s_per_rad
        self.host_id = host_id  # CAN_MASTER: the one host in 0..127 this motor answers
        self.last_host = host_id
        self._sent: deque = deque(maxlen=ECHO_MEMORY)  # (id, data) of own frames not yet heard back
        self.mode = MODE_RESET
        self.params = dict(self.DEFAULT_PARAMS)
        self.baud_code = 1
        self._faults: frozenset = frozenset()
        self._feedback_ids: dict[tuple, int] = {}  # (motor, host, mode, faults) -> type-2 id
        self._zero_rad = zero_offset_rad  # shaft angle that reads 0 (set by hand, or type 6: volatile)
        self._motion = (0.0, 0.0, 0.0, 0.0, 0.0)  # p_ref rad, v_ref rad/s, kp, kd, tau_ff N m
        self._speed_integral_a = 0.0
        self._quick_move_rad_s = 0.0  # run_mode 7 target speed (0 when its run flag is 0)
        self._calibration_done_s: float | None = None  # when the type-5 result is due
        self.table = self._stored_table(position_range)  # 0x0000-0x302F, types 8, 9 and 19
        self._handlers = self._handler_table()
        self._fixed_dlc = {cg.T_MOTION, cg.T_SET_ZERO, cg.T_PARAM_READ, cg.T_PARAM_WRITE, cg.T_SET_BAUD}

    @staticmethod
    def _stored_table(position_range: str) -> StoredTable | None:
        return StoredTable(position_range)

    def _layouts(self, position_range: str) -> Layouts:
        if position_range not in CYBERGEAR_FILES:
            raise ValueError(f"position_range must be one of {sorted(CYBERGEAR_FILES)}, got {position_range!r}")
        return Layouts.get(CYBERGEAR_FILES[position_range])

    def _handler_table(self) -> dict:
        """Communication type -> the method that answers it."""
        return {
            cg.T_DEVICE_ID: self._on_device_id, cg.T_MOTION: self._on_motion,
            cg.T_FEEDBACK: self._on_poll, cg.T_ENABLE: self._on_enable, cg.T_STOP: self._on_stop,
            cg.T_SET_ZERO: self._on_set_zero, cg.T_SET_ID: self._on_set_id,
            cg.T_PARAM_READ: self._on_read, cg.T_PARAM_WRITE: self._on_write,
            cg.T_FAULT_WARN: self._on_fault_poll, cg.T_SET_BAUD: self._on_set_baud,
            cg.T_BRAKE: self._on_brake, cg.T_CALIBRATE: self._on_calibrate,
            cg.T_PARAM_TABLE: self._on_table, cg.T_CONFIG_READ: self._on_config_read,
            cg.T_CONFIG_WRITE: self._on_config_write,
        }

    # -- state -----------------------------------------------------------------
    @property
    def faults(self) -> frozenset:
        """Latched faults, names from ``wheelleg.dbc.cybergear.FAULT_NAMES``."""
        return self._faults

    @property
    def run_mode(self) -> int:
        return self.params["run_mode"]

    @property
    def mech_pos(self) -> float:
        """rad, load-side multi-turn angle from the zero (0x7019)."""
        return self.shaft.angle - self._zero_rad

    def set_supply_voltage(self, vbus_v: float) -> None:
        """The supply the motor sees now (V): its back-EMF speed limit follows, VBUS reports it."""
        self.vbus_v = vbus_v
        line = self.LINE
        self.speed_limit_rad_s = line.speed_limit_rad_s * (vbus_v / line.supply_v)  # back-EMF: no drive beyond

    def supply_power_w(self, now_s: float) -> float:
        """W drawn from the supply now: shaft power plus the windings' copper loss (three phases at the
        firmware's current, each half the line resistance), negative when braking feeds it back."""
        current_a = self.firmware_torque() / self.LINE.torque_constant
        return self.output_torque(now_s) * self.shaft.speed + 1.5 * self.LINE.line_resistance_ohm * current_a * current_a

    @property
    def warn_over_temp(self) -> bool:
        return self.temperature_c >= self.LINE.warn_temp_c

    def inject_fault(self, name: str) -> None:
        """Latch a fault as the firmware would: torque off, reset mode, bit in every type-2 id."""
        if name not in cg.FAULT_NAMES:
            raise ValueError(f"unknown CyberGear fault {name!r}; expected one of {cg.FAULT_NAMES}")
        self._faults = self._faults | {name}
        self.mode = MODE_RESET

    def _frame_key(self, msg: can.Message) -> int:
        """Frozen replies repeat per communication type (the type-2 id changes with mode)."""
        return cg.comm_type(msg.arbitration_id)

    # -- physics -----------------------------------------------------------------
    def output_torque(self, now_s: float) -> float:
        """N m on the shaft: what the firmware makes times the true-torque scale."""
        return self.firmware_torque() * self.kt_scale

    def firmware_torque(self) -> float:
        """N m the firmware means to make (and reports): the run mode's demand within its limits.

        In brake mode the windings are shorted: the back-EMF drives a current
        that brakes the shaft, -K_EMF * speed (within +-12 N m).
        """
        # The plant asks ~10 times a control period per motor: the clamps are written out
        # (each as ``_clamp``, ``min`` and ``max`` decide, NaN included).
        mode, faults, speed, peak = self.mode, self._faults, self.shaft.speed, self._peak_nm
        if mode != MODE_RUN or faults:
            if mode == MODE_BRAKE and not faults:
                return _clamp(-self._back_emf * speed, -peak, peak)
            return 0.0
        limit = self.params["limit_torque"]
        if peak < limit:  # min(limit_torque, the motor's)
            limit = peak
        if self.params["run_mode"] == RUN_OPERATION:  # _demand_torque's MIT law, inline
            p_ref, v_ref, kp, kd, tau_ff = self._motion
            tau = kp * (p_ref - (self.shaft.angle - self._zero_rad)) + kd * (v_ref - speed) + tau_ff
        else:
            tau = self._demand_torque()
        tau = -limit if tau < -limit else limit if tau > limit else tau
        if tau * speed > 0.0:  # driving, not braking: back-EMF limit
            available = self._back_emf * (self.speed_limit_rad_s - abs(speed))
            if not available > 0.0:  # max(0.0, available)
                available = 0.0
            tau = -available if tau < -available else available if tau > available else tau
        return tau

    def _demand_torque(self) -> float:
        run_mode, p = self.params["run_mode"], self.params
        if run_mode == 0:
            p_ref, v_ref, kp, kd, tau_ff = self._motion
            return kp * (p_ref - self.mech_pos) + kd * (v_ref - self.shaft.speed) + tau_ff
        if run_mode == 3:
            limit_a = self.LINE.current_limit_a
            return _clamp(p["iq_ref"], -limit_a, limit_a) * self.LINE.torque_constant
        limit_cur = p["limit_cur"]
        iq = p["spd_kp"] * (self._speed_ref() - self.shaft.speed) + self._speed_integral_a
        return _clamp(iq, -limit_cur, limit_cur) * self.LINE.torque_constant

    def _speed_ref(self) -> float:
        p = self.params
        if p["run_mode"] in (RUN_POSITION, RUN_ZERO):  # zero return: position mode towards 0 rad
            target = p["loc_ref"] if p["run_mode"] == RUN_POSITION else 0.0
            return _clamp(p["loc_kp"] * (target - self.mech_pos), -p["limit_spd"], p["limit_spd"])
        speed = self._quick_move_rad_s if p["run_mode"] == RUN_QUICK_MOVE else p["spd_ref"]
        return _clamp(speed, -self.LINE.speed_limit_rad_s, self.LINE.speed_limit_rad_s)

    def advance(self, dt_s: float, now_s: float) -> None:
        if not dt_s > 0.0:
            return
        if self.mode == MODE_RUN and self.params["run_mode"] in self.SPEED_LOOP_MODES:
            limit = self.params["limit_cur"]
            err = self._speed_ref() - self.shaft.speed
            self._speed_integral_a = _clamp(
                self._speed_integral_a + self.params["spd_ki"] * SPEED_LOOP_HZ * err * dt_s, -limit, limit)
        line = self.LINE
        current = self.firmware_torque() / line.torque_constant
        settle = self.ambient_c + line.heat_k_per_a2 * current * current
        self.temperature_c += (settle - self.temperature_c) * (1.0 - math.exp(-dt_s / line.thermal_tau_s))
        if self.temperature_c >= line.over_temp_c and "FaultOverTemp" not in self._faults:
            self.inject_fault("FaultOverTemp")

    # -- frames in ---------------------------------------------------------------
    # its node hands it only extended frames addressed to its id: the first test of ``_handle``
    rx_filter = (True, cg.target, "motor_id")

    def _handle(self, msg: can.Message, now_s: float) -> list[can.Message]:
        can_id = msg.arbitration_id
        # most frames on the bus are for the other motors: the cheap tests first (a direct
        # caller's; its node already filtered them, ``rx_filter``)
        if not msg.is_extended_id or cg.target(can_id) != self.motor_id or not is_data_frame(msg):
            return []
        data = bytes(msg.data)
        if self._is_own_echo(can_id, data):
            return []
        ctype = cg.comm_type(can_id)
        handler = self._handlers.get(ctype)
        if handler is None or (ctype in self._fixed_dlc and len(data) != FULL_DLC):
            return []
        if ctype != cg.T_MOTION:  # type 1 has no sender field: only hosts send it
            if not cg.sent_by_host(can_id, self.host_id):
                return []  # another motor's reply to a host that shares this motor's id
            self.last_host = cg.request_host(can_id)
        return self._remember(handler(can_id, data, now_s))

    def _is_own_echo(self, can_id: int, data: bytes) -> bool:
        """A frame this motor sent, heard back (an echoing transport): consumed, never answered."""
        key = (can_id, data)
        if key in self._sent:
            self._sent.remove(key)
            return True
        return False

    def _remember(self, frames: list[can.Message]) -> list[can.Message]:
        for f in frames:
            if cg.target(f.arbitration_id) == self.motor_id:  # only a self-addressed frame can come back as a request
                self._sent.append((f.arbitration_id, bytes(f.data)))
        return frames

    def _on_device_id(self, can_id: int, data: bytes, now_s: float) -> list[can.Message]:
        return [self._device_id_frame(now_s)]

    def _on_motion(self, can_id: int, data: bytes, now_s: float) -> list[can.Message]:
        if self.mode == MODE_RUN and self.params["run_mode"] == RUN_OPERATION:
            raw = self._lay.motion.decode_raw(data)
            pos, vel, kp, kd = self._lay.motion_fields
            self._motion = (pos.value(raw["PosRef"]), vel.value(raw["VelRef"]), kp.value(raw["Kp"]),
                            kd.value(raw["Kd"]), self._id_torque(can_id))
        return [self._feedback_frame(self.last_host, now_s)]

    @staticmethod
    def _id_torque(can_id: int) -> float:
        """N m of a type-1 id's feed-forward field."""
        return cg.motion_torque(can_id)

    def _on_poll(self, can_id: int, data: bytes, now_s: float) -> list[can.Message]:
        return [self._feedback_frame(self.last_host, now_s)]

    def _on_enable(self, can_id: int, data: bytes, now_s: float) -> list[can.Message]:
        if not self._faults and self.mode not in (MODE_RUN, MODE_CALI):  # brake -> run too
            self.mode = MODE_RUN
            self._motion = (0.0, 0.0, 0.0, 0.0, 0.0)
            self._speed_integral_a = 0.0
        return [self._feedback_frame(self.last_host, now_s)]

    def _on_stop(self, can_id: int, data: bytes, now_s: float) -> list[can.Message]:
        self.mode = MODE_RESET
        self._calibration_done_s = None  # a stop aborts a calibration
        self._motion = (0.0, 0.0, 0.0, 0.0, 0.0)
        self._speed_integral_a = 0.0
        if self._lay.stop.decode_raw(data.ljust(FULL_DLC, b"\0"))["ClearFault"] == 1:
            self._faults = frozenset()
        return [self._feedback_frame(self.last_host, now_s)]

    def _on_brake(self, can_id: int, data: bytes, now_s: float) -> list[can.Message]:
        if not self._faults and self.mode in (MODE_RUN, MODE_RESET):
            self.mode = MODE_BRAKE
            self._speed_integral_a = 0.0
        return [self._feedback_frame(self.last_host, now_s)]

    def _on_calibrate(self, can_id: int, data: bytes, now_s: float) -> list[can.Message]:
        if self.mode != MODE_CALI:
            self.mode = MODE_CALI
            self._calibration_done_s = now_s + CALIBRATION_S
        return [self._feedback_frame(self.last_host, now_s)]

    def periodic(self, now_s: float) -> list[can.Message]:
        if self._calibration_done_s is None:  # nothing it sends unasked: asked 6 times a tick
            return []
        return super().periodic(now_s)

    def _periodic(self, now_s: float) -> list[can.Message]:
        """The one frame a CyberGear sends unasked: the type-5 calibration result, when it is done."""
        if self._calibration_done_s is None or now_s < self._calibration_done_s:
            return []
        self._calibration_done_s = None
        self.mode = MODE_RESET
        self._faults = self._faults - {"FaultNotCalibrated"}
        payload = self._lay.calibration.encode_raw({"ElecOffset": ELEC_OFFSET_RAD})
        return [frame(cg.reply_id(cg.T_CALIBRATE, self.motor_id, self.last_host), payload, True, now_s)]

    def _on_set_zero(self, can_id: int, data: bytes, now_s: float) -> list[can.Message]:
        if self._lay.set_zero.decode_raw(data)["ZeroFlag"] == 1:
            self._zero_rad = self.shaft.angle
        return [self._feedback_frame(self.last_host, now_s)]

    def _on_set_id(self, can_id: int, data: bytes, now_s: float) -> list[can.Message]:
        new_id = cg.set_id_new_id(can_id)
        if new_id <= MAX_MOTOR_ID and (new_id != self.host_id or new_id == self.motor_id):
            self.motor_id = new_id
        return [self._device_id_frame(now_s)]

    def _on_set_baud(self, can_id: int, data: bytes, now_s: float) -> list[can.Message]:
        code = self._lay.set_baud.decode_raw(data)["BaudCode"]
        if code in BAUD_CODES:
            self.baud_code = code  # recorded only: an emulated bus has no bit rate to change
        return [self._device_id_frame(now_s)]

    def _on_read(self, can_id: int, data: bytes, now_s: float) -> list[can.Message]:
        entry = self._lay.params.get(self._lay.index.decode_raw(data)["Index"])
        if entry is None:
            return []
        name, index, _, read_codec = entry
        payload = read_codec.encode_raw({"Index": index, name: self._read_param(name)})
        return [frame(cg.reply_id(cg.T_PARAM_READ, self.motor_id, self.last_host), payload, True, now_s)]

    def _on_write(self, can_id: int, data: bytes, now_s: float) -> list[can.Message]:
        entry = self._lay.params.get(self._lay.index.decode_raw(data)["Index"])
        if entry is not None and entry[0] == "run_mode" and data[4] == RUN_QUICK_MOVE and self._lay.quick_move:
            self._quick_move(self._lay.quick_move.decode(data))
        elif entry is not None and entry[0] not in self.READ_ONLY:
            name, _, write_codec, _ = entry
            self._write_param(name, write_codec.decode_raw(data)[name], write_codec.signals[name])
        return [self._feedback_frame(self.last_host, now_s)]

    def _on_table(self, can_id: int, data: bytes, now_s: float) -> list[can.Message]:
        return self.table.dump(self._live_table(), self.motor_id, self.last_host, now_s)

    def _on_config_read(self, can_id: int, data: bytes, now_s: float) -> list[can.Message]:
        return self.table.read(data, self._live_table(), self.motor_id, self.last_host, now_s)

    def _on_config_write(self, can_id: int, data: bytes, now_s: float) -> list[can.Message]:
        self.table.write(data)
        return []

    def _live_table(self) -> dict:
        """Stored-table entries that are the motor's own state (docs/protocols.md, parameter table)."""
        iq_a = self.firmware_torque() / self.LINE.torque_constant
        return {"CAN_ID": self.motor_id, "CAN_MASTER": self.host_id,
                "motorTemp": round(self.temperature_c * 10), "vBus_mv": round(self.vbus_v * 1000),
                "VBUS": self.vbus_v, "v_bus": self.vbus_v, "rotation": self._read_param("rotation"),
                "mechPos": self.mech_pos, "mechVel": self.shaft.speed, "iqf": iq_a, "iq": iq_a,
                "torque_fdb": self.firmware_torque()}

    def _on_fault_poll(self, can_id: int, data: bytes, now_s: float) -> list[can.Message]:
        raw = {s: 0 for s in self._lay.fault_warn.signals}
        for fault in self._faults:
            if fault in FAULT_WORD:
                raw[FAULT_WORD[fault]] = 1
        raw["WarnOverTemp"] = int(self.warn_over_temp)
        payload = self._lay.fault_warn.encode_raw(raw)
        return [frame(cg.reply_id(cg.T_FAULT_WARN, self.motor_id, self.last_host), payload, True, now_s)]

    def _quick_move(self, jog: dict) -> None:
        """run_mode 7, the debugger's jog: taken in any mode (the public driver sends it enabled); its
        run flag turns a stopped motor without a separate enable, as the debugger's jog buttons do."""
        self.params["run_mode"] = RUN_QUICK_MOVE
        if jog["Run"] == 1 and self.mode == MODE_RESET and not self._faults:
            self.mode = MODE_RUN
            self._speed_integral_a = 0.0
        speed = jog["Speed"] if jog["Run"] == 1 else 0.0
        self._quick_move_rad_s = _clamp(speed, -self.LINE.speed_limit_rad_s, self.LINE.speed_limit_rad_s)

    # -- parameters --------------------------------------------------------------
    def _read_param(self, name: str):
        if name == "mechPos":
            return self.mech_pos
        if name == "mechVel":
            return self.shaft.speed
        if name == "iqf":
            return self.firmware_torque() / self.LINE.torque_constant
        if name == "VBUS":
            return self.vbus_v
        if name == "rotation":
            return int(_clamp(math.floor(self.mech_pos / (2 * math.pi)), -32768, 32767))
        return self.params[name]

    def _write_param(self, name: str, value, signal) -> None:
        if name == "run_mode":
            if self.mode == MODE_RESET and value in self.RUN_MODES:
                self.params[name] = int(value)
            return
        if name == "rotation":  # keep the angle within the turn, move the turn count
            self._zero_rad -= 2 * math.pi * (value - self._read_param("rotation"))
            return
        if not math.isfinite(value):
            return
        value = _clamp(value, signal.minimum, signal.maximum)
        self.params[name] = float(value) if signal.float_format is not None else int(value)

    # -- frames out --------------------------------------------------------------
    def _feedback_frame(self, host: int, now_s: float) -> can.Message:
        payload = self._lay.feedback_payload(self.mech_pos, self.shaft.speed, self.firmware_torque(),
                                             self.temperature_c)
        key = (self.motor_id, host, self.mode, self._faults)
        can_id = self._feedback_ids.get(key)
        if can_id is None:
            can_id = self._feedback_ids[key] = cg.reply_id(cg.T_FEEDBACK, *key)
        return frame(can_id, payload, True, now_s)

    def _device_id_frame(self, now_s: float) -> can.Message:
        can_id = cg.reply_id(cg.T_DEVICE_ID, self.motor_id, cg.DEVICE_ID_TARGET)
        return frame(can_id, self._lay.device_id.encode_raw({"McuUid": self.uid}), True, now_s)
