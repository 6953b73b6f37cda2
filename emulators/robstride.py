"""RobStride RS01, RS02, RS03, RS04 actuators, frame for frame (docs/protocols.md, RobStride).

The private protocol is the CyberGear's (emulators/cybergear.py, whose reply
rules, identifier fields, fault bits and echo handling this class inherits):
type 0 device id, 1 MIT command, 3 enable, 4 stop, 6 zero, 7 change id, 17/18
parameter read/write, 21 fault words. What differs is described here and in
each model's DBC (dbc/robstride_rs0N.dbc): the scales (position +-4 pi rad;
speed, torque, Kp, Kd ranges per model), the parameter list (0x7005-0x7029)
and RobStride's own commands:

* Type 22 saves the parameters (payload 01..08): answered by type 2.
* Type 23 changes the bit rate (code in byte 6, after 01..06): recorded,
  answered by type 0 (an emulated bus has no bit rate).
* Type 24 turns active reporting on or off (byte 6): while on, the motor sends
  its type-2 frame every EPScan_time (1 = 10 ms, each step 5 ms more).
* Type 25 switches the protocol (byte 6: 0 private, 1 CANopen, 2 MIT):
  recorded and answered by type 0; it takes effect at a power cycle, which an
  emulator does not have, so the motor keeps speaking the private protocol.
* run_mode (0x7005): 0 MIT, 1 profile position (speed limit vel_max), 2
  speed, 3 current, 5 cyclic position (speed limit limit_spd); types 5, 8,
  9, 19 and 20 (CyberGear's calibration, stored table and brake) are not
  RobStride's: silence.
* canTimeout (0x7028, units of 50 us): when non-zero and no frame came for
  that long, a running motor drops to reset mode (the offline behaviour).

Choices where the manuals are silent (docs/protocols.md): the 6-byte magic of
types 23-25 (01 02 03 04 05 06) and the 8-byte one of type 22 are required
(else silence); the motor line (peak torque, back-EMF line to zero at the
speed field's range, thermal model) is the CyberGear's with each model's
figures (``MODELS``); zero_sta (0x7029) is stored, not applied.
"""
from __future__ import annotations

from dataclasses import dataclass

import can

from wheelleg.dbc import cybergear as cg
from wheelleg.dbc import load_file
from wheelleg.emulators.cybergear import CYBERGEAR_LINE, MODE_RESET, MODE_RUN, RUN_SPEED, CyberGear
from wheelleg.emulators.cybergear_family import Layouts, MotorLine
from wheelleg.emulators.device import EmulatedDevice, PeriodicSchedule, Shaft

T_SAVE, T_BAUD, T_REPORT, T_PROTOCOL = 22, 23, 24, 25
RUN_PROFILE_POSITION, RUN_CSP_POSITION = 1, 5
MAGIC6 = int.from_bytes(bytes(range(1, 7)), "little")
MAGIC8 = int.from_bytes(bytes(range(1, 9)), "little")
TIMEOUT_UNIT_S = 50e-6  # canTimeout: 20000 = 1 s
NOMINAL_SUPPLY_V = 48.0


@dataclass(frozen=True)
class RobStrideModel:
    name: str
    dbc: str
    rated_torque_nm: float
    line: MotorLine


def _line(peak_nm: float, speed_rad_s: float, current_a: float, rated_nm: float) -> MotorLine:
    """A model's line: Kt = peak torque / peak current; full torque up to 70 % of the speed range;
    rated torque continuous settles 45 K above ambient (⚠ thermal figures and the CyberGear's line resistance
    assumed, see docs/protocols.md)."""
    kt = peak_nm / current_a
    return MotorLine(peak_nm, speed_rad_s, peak_nm / (0.3 * speed_rad_s), kt, current_a,
                     CYBERGEAR_LINE.thermal_tau_s, 45.0 / (rated_nm / kt) ** 2,
                     CYBERGEAR_LINE.over_temp_c, CYBERGEAR_LINE.warn_temp_c, NOMINAL_SUPPLY_V,
                     CYBERGEAR_LINE.line_resistance_ohm)


# Each model's manual: peak torque, the speed field's range, peak current, rated torque.
MODELS = {
    "RS01": RobStrideModel("RS01", "robstride_rs01.dbc", 6.0, _line(17.0, 44.0, 23.0, 6.0)),
    "RS02": RobStrideModel("RS02", "robstride_rs02.dbc", 6.0, _line(17.0, 44.0, 23.0, 6.0)),
    "RS03": RobStrideModel("RS03", "robstride_rs03.dbc", 20.0, _line(60.0, 50.0, 43.0, 20.0)),
    "RS04": RobStrideModel("RS04", "robstride_rs04.dbc", 40.0, _line(120.0, 15.0, 90.0, 40.0)),
}


def default_params(model: RobStrideModel) -> dict:
    """Runtime parameters at power-up: the CyberGear's gains (⚠), this model's limits, RobStride's extras."""
    line = model.line
    return {"run_mode": 0, "iq_ref": 0.0, "spd_ref": 0.0, "limit_torque": line.torque_limit_nm, "cur_kp": 0.17,
            "cur_ki": 0.012, "cur_filt_gain": 0.1, "loc_ref": 0.0, "limit_spd": 2.0,
            "limit_cur": line.current_limit_a, "loc_kp": 30.0, "spd_kp": 1.0, "spd_ki": 0.002,
            "spd_filt_gain": 0.1, "acc_rad": 20.0, "vel_max": 2.0, "acc_set": 10.0, "EPScan_time": 1,
            "canTimeout": 0, "zero_sta": 0}


class RobStride(CyberGear):
    """One RobStride actuator (``model`` RS01..RS04) on a CAN bus (29-bit ids)."""

    UID_BASE = 0x5253_0000_0000_0000  # "RS"
    RUN_MODES = (0, 1, 2, 3, 5)
    SPEED_LOOP_MODES = (RUN_PROFILE_POSITION, RUN_SPEED, RUN_CSP_POSITION)

    def __init__(self, model: str = "RS01", motor_id: int = 0x7F, uid: int | None = None, ambient_c: float = 25.0,
                 host_id: int = 0x00, vbus_v: float = NOMINAL_SUPPLY_V, shaft: Shaft | None = None,
                 kt_scale: float = 1.0):
        if model not in MODELS:
            raise ValueError(f"unknown RobStride model {model!r}; expected one of {sorted(MODELS)}")
        self.model = MODELS[model]
        self.LINE = self.model.line
        self.DEFAULT_PARAMS = default_params(self.model)
        super().__init__(motor_id=motor_id, position_range=model, uid=uid, ambient_c=ambient_c, host_id=host_id,
                         vbus_v=vbus_v, shaft=shaft, kt_scale=kt_scale)
        torque = load_file(self.model.dbc).get_message_by_name("RS_Id_Motion").get_signal_by_name("TorqueRef")
        self._torque_field = (torque.start, (1 << torque.length) - 1, torque.scale, torque.offset)
        self.baud_code = 1
        self.protocol = 0  # 0 private; a type-25 switch waits for a power cycle
        self.saved_params = dict(self.params)
        self._report: PeriodicSchedule | None = None
        self._last_rx_s: float | None = None

    @staticmethod
    def _stored_table(position_range: str) -> None:
        return None  # no stored table: types 8, 9 and 19 are CyberGear's

    def _layouts(self, position_range: str) -> Layouts:
        return Layouts.get(MODELS[position_range].dbc, "RS")

    def _handler_table(self) -> dict:
        return {
            cg.T_DEVICE_ID: self._on_device_id, cg.T_MOTION: self._on_motion, cg.T_ENABLE: self._on_enable,
            cg.T_STOP: self._on_stop, cg.T_SET_ZERO: self._on_set_zero, cg.T_SET_ID: self._on_set_id,
            cg.T_PARAM_READ: self._on_read, cg.T_PARAM_WRITE: self._on_write, cg.T_FAULT_WARN: self._on_fault_poll,
            T_SAVE: self._on_save, T_BAUD: self._on_baud, T_REPORT: self._on_report, T_PROTOCOL: self._on_protocol,
        }

    def _id_torque(self, can_id: int) -> float:
        shift, mask, scale, offset = self._torque_field
        return ((can_id >> shift) & mask) * scale + offset

    # -- RobStride's own commands ------------------------------------------------------
    @staticmethod
    def _magic(data: bytes) -> int | None:
        """Byte 6 of a type 23-25 request whose bytes 0..5 are the magic 01..06, else None."""
        if len(data) < 7 or int.from_bytes(data[:6], "little") != MAGIC6:
            return None
        return data[6]

    def _on_save(self, can_id: int, data: bytes, now_s: float) -> list[can.Message]:
        if int.from_bytes(data.ljust(8, b"\0"), "little") != MAGIC8:
            return []
        self.saved_params = dict(self.params)
        return [self._feedback_frame(self.last_host, now_s)]

    def _on_baud(self, can_id: int, data: bytes, now_s: float) -> list[can.Message]:
        code = self._magic(data)
        if code is None:
            return []
        if code in (1, 2, 3, 4):
            self.baud_code = code  # recorded only: an emulated bus has no bit rate
        return [self._device_id_frame(now_s)]

    def _on_report(self, can_id: int, data: bytes, now_s: float) -> list[can.Message]:
        flag = self._magic(data)
        if flag is None:
            return []
        if flag == 1:
            period = 0.010 + 0.005 * (max(1, int(self.params["EPScan_time"])) - 1)
            self._report = PeriodicSchedule(period)
        elif flag == 0:
            self._report = None
        return [self._feedback_frame(self.last_host, now_s)]

    def _on_protocol(self, can_id: int, data: bytes, now_s: float) -> list[can.Message]:
        code = self._magic(data)
        if code is None:
            return []
        if code in (0, 1, 2):
            self.protocol = code
        return [self._device_id_frame(now_s)]

    # -- offline behaviour, active reporting ---------------------------------------------
    def _handle(self, msg: can.Message, now_s: float) -> list[can.Message]:
        replies = super()._handle(msg, now_s)
        if replies:  # a request it took (every taken request is answered)
            self._last_rx_s = now_s
        return replies

    def advance(self, dt_s: float, now_s: float) -> None:
        super().advance(dt_s, now_s)
        timeout = self.params["canTimeout"] * TIMEOUT_UNIT_S
        if (timeout > 0.0 and self.mode == MODE_RUN and self._last_rx_s is not None
                and now_s - self._last_rx_s > timeout):
            self.mode = MODE_RESET

    def periodic(self, now_s: float) -> list[can.Message]:
        if self._report is None:
            return []
        return EmulatedDevice.periodic(self, now_s)

    def _periodic(self, now_s: float) -> list[can.Message]:
        return [self._feedback_frame(self.last_host, now_s)] if self._report.due(now_s) else []

    # -- control ---------------------------------------------------------------------
    def _speed_ref(self) -> float:
        p = self.params
        if p["run_mode"] in (RUN_PROFILE_POSITION, RUN_CSP_POSITION):
            limit = p["vel_max"] if p["run_mode"] == RUN_PROFILE_POSITION else p["limit_spd"]
            return max(-limit, min(limit, p["loc_kp"] * (p["loc_ref"] - self.mech_pos)))
        return max(-self.LINE.speed_limit_rad_s, min(self.LINE.speed_limit_rad_s, p["spd_ref"]))

