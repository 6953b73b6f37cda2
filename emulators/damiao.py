"""Damiao DM-J joint motors (DM-J4310-2EC, DM-J4340-2EC, DM-J8009P-2EC), frame for frame (docs/protocols.md).

One-to-one protocol on standard ids (dbc/damiao.dbc). Commands go to the
motor's ESC_ID (register 8) plus the control mode's offset: MIT at ESC_ID,
position-speed at 0x100 + ESC_ID, speed at 0x200 + ESC_ID, force-position at
0x300 + ESC_ID; register access at 0x7FF. Every reply goes to MST_ID
(register 7, "the master id").

Reply rules: every accepted command frame and every special frame (seven
0xFF then 0xFC enable, 0xFD disable, 0xFE zero, 0xFB clear error) is answered
by one feedback frame; a register read (0x33) or write (0x55) by the register
frame with the register's value after the write; a store (0xAA) by
``[id, 0xAA, 0x01]``; a refresh (0xCC) by a feedback frame. The motor sends
nothing on its own.

Choices where the sources are silent (docs/protocols.md), made once here:

* A command for a control mode other than CTRL_MODE (register 10) is not
  obeyed and not answered (damiao-motor: "the motor will not respond"); the
  special frames are taken at any mode's id.
* Frames must be standard-id data frames of DLC 8; others: silence.
* Writes to ESC_ID or MST_ID take effect at once (a real motor needs a store
  and a power cycle); a write of a read-only register, an unknown register or
  a value outside the DBC range is answered with the register's unchanged
  value. Stores are taken only while disabled (the manual's rule).
* The speed and position loops (KP_ASR, KI_ASR, KP_APR) are PI/P laws in SI
  units: N m per rad/s, N m per rad, rad/s per rad (the firmware's own units
  are not published); the emulator's defaults hold a small inertia steadily.
* TIMEOUT (register 9, units of 50 us): when non-zero and no command came for
  that long while enabled, the motor disables itself with state 0xD (lost
  communication); 0 never (the factory value).
* A fault (state 8..0xE) cuts the torque until a clear-error frame; enable is
  refused meanwhile.

Model: the output torque is clamped to the model's peak torque and by a
back-EMF line to zero at the no-load speed (scaled by the supply voltage);
the rotor temperature is first order in the torque squared and latches state
0xC above OT_Value (register 2); the supply below UV_Value latches 9.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import can

from wheelleg.dbc import load_file
from wheelleg.dbc.codec import MessageCodec, truncate
from wheelleg.emulators.device import EmulatedDevice, Shaft, frame, is_data_frame

FULL_DLC = 8
REGISTER_ID = 0x7FF
MODE_OFFSET = {1: 0x000, 2: 0x100, 3: 0x200, 4: 0x300}  # CTRL_MODE -> command id offset
MIT, POS_VEL, VEL, FORCE_POS = 1, 2, 3, 4
ENABLE, DISABLE, SET_ZERO, CLEAR_ERROR = 0xFC, 0xFD, 0xFE, 0xFB
READ, WRITE, STORE, REFRESH = 0x33, 0x55, 0xAA, 0xCC
DISABLED, ENABLED = 0x0, 0x1
FAULTS = {"over_voltage": 0x8, "under_voltage": 0x9, "over_current": 0xA, "mos_over_temp": 0xB,
          "rotor_over_temp": 0xC, "lost_comm": 0xD, "overload": 0xE}
KP_MAX, KD_MAX = 500.0, 5.0  # MIT gain ranges, every model (DM_CAN)
TIMEOUT_UNIT_S = 50e-6
THERMAL_TAU_S = 300.0  # ⚠ assumed: no thermal data published
MOS_SHARE = 0.5  # ⚠ assumed: the MOSFETs rise half as much as the rotor
# read-only registers (the manual's register table); the rest are read-write
READ_ONLY = frozenset({11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 36, 50, 51, 52, 53, 54, 55, 80, 81})


@dataclass(frozen=True)
class DamiaoModel:
    """One DM-J model: its MIT ranges (PMAX/VMAX/TMAX factory values) and motor line, output side."""

    name: str
    pmax: float  # rad
    vmax: float  # rad/s
    tmax: float  # N m (the field's range)
    peak_torque_nm: float
    rated_torque_nm: float
    no_load_speed_rad_s: float  # at supply_v
    supply_v: float
    gear: float
    torque_constant: float  # N m/A at the output (KT_Value, register 1)


def _rpm(x: float) -> float:
    return x * 2 * math.pi / 60


# Datasheets (docs/protocols.md): ranges from Damiao's DM_CAN Limit_Param table; torques and speeds
# from each model's manual; ⚠ marks a figure inferred, not printed.
MODELS = {
    "DM-J4310-2EC": DamiaoModel("DM-J4310-2EC", 12.5, 30.0, 10.0, 7.0, 3.0, _rpm(200), 24.0, 10.0, 0.945),
    "DM-J4340-2EC": DamiaoModel("DM-J4340-2EC", 12.5, 8.0, 28.0, 27.0, 9.0, _rpm(52), 24.0, 40.0, 3.6),
    "DM-J8009P-2EC": DamiaoModel("DM-J8009P-2EC", 12.5, 45.0, 54.0, 40.0, 20.0, _rpm(300), 48.0, 9.0, 1.261),
}


class _Layouts:
    """Codecs of dbc/damiao.dbc, built once."""

    _instance: "_Layouts | None" = None

    def __init__(self):
        db = load_file("damiao.dbc")
        msg = db.get_message_by_name
        self.mit = MessageCodec.of(msg("DM_MitCmd"))
        self.feedback = MessageCodec.of(msg("DM_Feedback"))
        self.pos_vel = MessageCodec.of(msg("DM_PosVelCmd"))
        self.vel = MessageCodec.of(msg("DM_VelCmd"))
        self.force_pos = MessageCodec.of(msg("DM_ForcePosCmd"))
        self.special = MessageCodec.of(msg("DM_Special"))
        self.fill = tuple(self.special.signals[n].mask for n in ("FillLow", "FillHigh"))  # seven 0xFF bytes
        self.registers = {}  # rid -> (name, codec of that register's frame, its signal)
        reg = msg("DM_Register")
        fixed = [reg.get_signal_by_name(n) for n in ("Rid", "TargetId", "Op")]
        self.register_head = MessageCodec(reg, fixed)  # any register frame's first four bytes
        for sig in reg.signals:
            for rid in sig.multiplexer_ids or ():
                self.registers[rid] = (sig.name, MessageCodec(reg, [*fixed, sig]), sig)

    @classmethod
    def get(cls) -> "_Layouts":
        if cls._instance is None:
            cls._instance = cls()
        return cls._instance


def _to_float(raw: int, lo: float, hi: float, bits: int) -> float:
    """The manual's uint_to_float: ``raw`` of a ``bits`` field over [lo, hi]."""
    return raw * (hi - lo) / ((1 << bits) - 1) + lo


def _clamp(x: float, lo: float, hi: float) -> float:
    return lo if x < lo else hi if x > hi else x


def default_registers(model: DamiaoModel, esc_id: int, master_id: int) -> dict[str, float]:
    """Power-up register values: the model's data, the manual's defaults, ⚠ the emulator's loop gains."""
    return {
        "UV_Value": 10.0, "KT_Value": model.torque_constant, "OT_Value": 120.0, "OC_Value": 0.98,
        "ACC": 10.0, "DEC": -10.0, "MAX_SPD": model.vmax, "MST_ID": master_id, "ESC_ID": esc_id, "TIMEOUT": 0,
        "CTRL_MODE": MIT, "Damp": 0.0, "Inertia": 0.0, "hw_ver": 1, "sw_ver": 5013, "SN": 0, "NPP": 14,
        "Rs": 0.5, "Ls": 2e-4, "Flux": 0.01, "Gr": model.gear, "PMAX": model.pmax, "VMAX": model.vmax,
        "TMAX": model.tmax, "I_BW": 1000.0, "KP_ASR": 0.05 * model.peak_torque_nm, "KI_ASR": 0.5 * model.peak_torque_nm,
        "KP_APR": 10.0, "KI_APR": 0.0, "OV_Value": 2.5 * model.supply_v, "GREF": 1.0, "Deta": 4.0, "V_BW": 100.0,
        "IQ_c1": 200.0, "VL_c1": 200.0, "can_br": 4, "sub_ver": 1, "u_off": 0.0, "v_off": 0.0, "k1": 0.0,
        "k2": 0.0, "m_off": 0.0, "dir": 1.0, "p_m": 0.0, "xout": 0.0,
    }


class Damiao(EmulatedDevice):
    """One DM-J motor; see the module docstring for the rules."""

    def __init__(self, model: str = "DM-J4310-2EC", esc_id: int = 1, master_id: int = 0x00,
                 ambient_c: float = 25.0, shaft: Shaft | None = None, supply_v: float | None = None,
                 kt_scale: float = 1.0):
        super().__init__(shaft)
        if model not in MODELS:
            raise ValueError(f"unknown Damiao model {model!r}; expected one of {sorted(MODELS)}")
        if not (1 <= esc_id <= 0x7FF and esc_id != REGISTER_ID and 0 <= master_id <= 0x7FF):
            raise ValueError(f"Damiao ESC_ID must be 1..0x7FE and MST_ID 0..0x7FF, got {esc_id:#x}, {master_id:#x}")
        self.model = MODELS[model]
        self.supply_v = self.model.supply_v if supply_v is None else supply_v
        if not (self.supply_v > 0.0 and kt_scale > 0.0):
            raise ValueError(f"supply_v and kt_scale must be > 0, got {self.supply_v!r}, {kt_scale!r}")
        self.kt_scale = kt_scale
        self._lay = _Layouts.get()
        self.registers = default_registers(self.model, esc_id, master_id)
        self.ambient_c = ambient_c
        self.temperature_c = ambient_c  # rotor
        self.enabled = False
        self.fault: int | None = None  # a FAULTS code while latched
        self._zero_rad = 0.0
        self._target = (0.0, 0.0, 0.0, 0.0, 0.0)  # mode-specific command, see _demand_torque
        self._speed_integral = 0.0
        self._last_command_s: float | None = None

    # -- ids ---------------------------------------------------------------------
    @property
    def esc_id(self) -> int:
        return int(self.registers["ESC_ID"])

    @property
    def master_id(self) -> int:
        return int(self.registers["MST_ID"])

    @property
    def control_mode(self) -> int:
        return int(self.registers["CTRL_MODE"])

    @property
    def position(self) -> float:
        """rad, output side, from the zero."""
        return self.shaft.angle - self._zero_rad

    @property
    def state(self) -> int:
        """The feedback's state nibble."""
        return self.fault if self.fault is not None else ENABLED if self.enabled else DISABLED

    def set_supply_voltage(self, supply_v: float) -> None:
        """The supply the motor sees now (V): the no-load speed and the voltage faults follow it."""
        self.supply_v = supply_v

    def supply_power_w(self, now_s: float) -> float:
        """W drawn from the supply now: shaft power plus the windings' loss (three phases, Rs each, at
        the current the torque needs through KT_Value)."""
        kt = self.registers["KT_Value"] or self.model.torque_constant  # a KT_Value of 0 may be written
        current = self.firmware_torque(now_s) / kt
        return self.output_torque(now_s) * self.shaft.speed + 1.5 * self.registers["Rs"] * current * current

    def inject_fault(self, name: str) -> None:
        """Latch a fault (``FAULTS``): torque off until a clear-error frame."""
        if name not in FAULTS:
            raise ValueError(f"unknown Damiao fault {name!r}; expected one of {sorted(FAULTS)}")
        self.fault = FAULTS[name]
        self.enabled = False

    # -- frames in ---------------------------------------------------------------
    def _handle(self, msg: can.Message, now_s: float) -> list[can.Message]:
        if msg.is_extended_id or len(msg.data) != FULL_DLC or not is_data_frame(msg):
            return []
        data, can_id = bytes(msg.data), msg.arbitration_id
        if can_id == REGISTER_ID:
            return self._on_register(data, now_s)
        offset = can_id - self.esc_id
        if offset not in MODE_OFFSET.values():
            return []
        special = self._lay.special.decode_raw(data)
        if (special["FillLow"], special["FillHigh"]) == self._lay.fill and special["Command"] in (ENABLE, DISABLE, SET_ZERO, CLEAR_ERROR):
            self._on_special(special["Command"])
            return [self._feedback_frame(now_s)]
        if offset != MODE_OFFSET[self.control_mode]:
            return []  # a command for another control mode: not obeyed, not answered
        self._on_command(data, now_s)
        return [self._feedback_frame(now_s)]

    def _on_special(self, command: int) -> None:
        if command == ENABLE and self.fault is None:
            if not self.enabled:
                self._speed_integral = 0.0
                self._target = (self.position, 0.0, 0.0, 0.0, 0.0) if self.control_mode != MIT else (0.0,) * 5
            self.enabled = True
        elif command == DISABLE:
            self.enabled = False
        elif command == SET_ZERO:
            self._zero_rad = self.shaft.angle
        elif command == CLEAR_ERROR:
            self.fault = None

    def _on_command(self, data: bytes, now_s: float) -> None:
        self._last_command_s = now_s
        r = self.registers
        mode = self.control_mode
        if mode == MIT:
            raw = self._lay.mit.decode_raw(data)
            self._target = (_to_float(raw["PosRef"], -r["PMAX"], r["PMAX"], 16),
                            _to_float(raw["VelRef"], -r["VMAX"], r["VMAX"], 12),
                            _to_float(raw["Kp"], 0.0, KP_MAX, 12), _to_float(raw["Kd"], 0.0, KD_MAX, 12),
                            _to_float(raw["TorqueRef"], -r["TMAX"], r["TMAX"], 12))
            return
        codec = {POS_VEL: self._lay.pos_vel, VEL: self._lay.vel, FORCE_POS: self._lay.force_pos}[mode]
        v = codec.decode(data)
        if not all(math.isfinite(x) for x in v.values()):
            return  # a NaN or infinite target is ignored (the last one holds)
        if mode == POS_VEL:
            self._target = (v["PosRef"], abs(v["VelLimit"]), self.model.peak_torque_nm, 0.0, 0.0)
        elif mode == VEL:
            self._target = (0.0, v["VelRef"], self.model.peak_torque_nm, 0.0, 0.0)
        else:
            self._target = (v["PosRef"], min(v["VelLimit"], 100.0), min(v["TorqueRatio"], 1.0) * r["TMAX"], 0.0, 0.0)

    def _on_register(self, data: bytes, now_s: float) -> list[can.Message]:
        head = self._lay.register_head.decode_raw(data)
        if head["TargetId"] != self.esc_id:
            return []
        op, rid = head["Op"], head["Rid"]
        if op == REFRESH:
            return [self._feedback_frame(now_s)]
        if op == STORE:
            if self.enabled:
                return []
            return [frame(self.master_id, bytes([data[0], data[1], STORE, 0x01, 0, 0, 0, 0]), False, now_s)]
        if op not in (READ, WRITE) or rid not in self._lay.registers:
            return []
        name, codec, signal = self._lay.registers[rid]
        if op == WRITE and rid not in READ_ONLY:
            self._write(name, codec.decode_raw(data)[name], signal)
        value = self._read(name)
        payload = codec.encode_raw({"TargetId": head["TargetId"], "Op": op, "Rid": rid,
                                    name: float(value) if signal.is_float else int(value)})
        return [frame(self.master_id, payload, False, now_s)]

    def _write(self, name: str, value, signal) -> None:
        if signal.is_float and not math.isfinite(value):
            return
        if not signal.minimum <= value <= signal.maximum:
            return
        if name == "ESC_ID" and value in (0, REGISTER_ID):
            return
        if name == "CTRL_MODE" and value != self.registers[name]:
            self.enabled = False  # a mode change while running: the manual's precaution, disable first
        self.registers[name] = value

    def _read(self, name: str):
        if name in ("p_m", "xout"):
            return self.position
        return self.registers[name]

    # -- frames out --------------------------------------------------------------
    def _feedback_frame(self, now_s: float) -> can.Message:
        r = self.registers
        raw = {"Id": self.esc_id & 0xF, "State": self.state,
               "Pos": truncate(-r["PMAX"], r["PMAX"], 0xFFFF, self.position),
               "Vel": truncate(-r["VMAX"], r["VMAX"], 0xFFF, self.shaft.speed),
               "Torque": truncate(-r["TMAX"], r["TMAX"], 0xFFF, self.firmware_torque(now_s)),
               "TempMos": int(_clamp(self.ambient_c + MOS_SHARE * (self.temperature_c - self.ambient_c), 0, 255)),
               "TempRotor": int(_clamp(self.temperature_c, 0, 255))}
        return frame(self.master_id, self._lay.feedback.encode_raw(raw), False, now_s)

    # -- physics -----------------------------------------------------------------
    def firmware_torque(self, now_s: float) -> float:
        """N m the firmware makes (and reports): the mode's law within the peak torque and the back-EMF line."""
        if not self.enabled or self.fault is not None:
            return 0.0
        tau = self._demand_torque()
        peak = self.model.peak_torque_nm
        tau = _clamp(tau, -peak, peak)
        speed = self.shaft.speed
        if tau * speed > 0.0:
            no_load = self.model.no_load_speed_rad_s * self.supply_v / self.model.supply_v
            available = max(0.0, peak * (1.0 - abs(speed) / no_load))
            tau = _clamp(tau, -available, available)
        return tau

    def _demand_torque(self) -> float:
        p_ref, v_ref, a, b, c = self._target
        if self.control_mode == MIT:  # a, b, c = Kp, Kd, tau_ff
            return a * (p_ref - self.position) + b * (v_ref - self.shaft.speed) + c
        # speed loop (PI) under the position loop; a is the torque limit
        return _clamp(self.registers["KP_ASR"] * self._speed_error() + self._speed_integral, -a, a)

    def _speed_error(self) -> float:
        """rad/s the speed loop corrects: to the speed target, or to the position loop's (v_ref its limit)."""
        p_ref, v_ref, *_ = self._target
        if self.control_mode != VEL:
            v_ref = _clamp(self.registers["KP_APR"] * (p_ref - self.position), -v_ref, v_ref)
        return v_ref - self.shaft.speed

    def output_torque(self, now_s: float) -> float:
        return self.firmware_torque(now_s) * self.kt_scale

    def advance(self, dt_s: float, now_s: float) -> None:
        if not dt_s > 0.0:
            return
        r = self.registers
        if self.enabled and self.control_mode != MIT:
            limit = self._target[2]
            self._speed_integral = _clamp(self._speed_integral + r["KI_ASR"] * self._speed_error() * dt_s,
                                          -limit, limit)
        if (self.enabled and r["TIMEOUT"] > 0 and self._last_command_s is not None
                and now_s - self._last_command_s > r["TIMEOUT"] * TIMEOUT_UNIT_S):
            self.inject_fault("lost_comm")
        load = self.firmware_torque(now_s) / self.model.rated_torque_nm
        settle = self.ambient_c + 60.0 * load * load  # ⚠ rated torque continuous: +60 K
        self.temperature_c += (settle - self.temperature_c) * (1.0 - math.exp(-dt_s / THERMAL_TAU_S))
        if self.fault is None:
            if self.temperature_c > r["OT_Value"]:
                self.inject_fault("rotor_over_temp")
            elif self.supply_v < r["UV_Value"]:
                self.inject_fault("under_voltage")
            elif self.supply_v > r["OV_Value"]:
                self.inject_fault("over_voltage")

