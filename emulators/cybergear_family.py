"""What the CyberGear protocol family shares (emulators/cybergear.py, emulators/robstride.py).

``MotorLine``: what a motor of the family can do (the numbers the emulator's
physics reads). ``Layouts``: the codecs of one family member's DBC, its
messages named ``PREFIX_...`` (``CG_`` CyberGear, ``RS_`` RobStride), built
once per DBC.
"""
from __future__ import annotations

from dataclasses import dataclass

from wheelleg.dbc import cybergear as cg
from wheelleg.dbc import load_file
from wheelleg.dbc.codec import MessageCodec


@dataclass(frozen=True)
class MotorLine:
    """What a motor of the CyberGear protocol family can do (output side, SI units, at ``supply_v``)."""

    torque_limit_nm: float  # peak torque
    speed_limit_rad_s: float  # no drive beyond (the back-EMF line's zero)
    back_emf_nm_s_per_rad: float  # the line's slope
    torque_constant: float  # N m/A
    current_limit_a: float  # iq_ref / limit_cur range
    thermal_tau_s: float
    heat_k_per_a2: float
    over_temp_c: float  # the fault
    warn_temp_c: float  # the warning
    supply_v: float  # nominal
    line_resistance_ohm: float  # phase to phase: the copper loss in supply_power_w


class Layouts:
    """Codecs of one DBC of the CyberGear protocol family (message names ``PREFIX_...``), built once.

    Messages a family member lacks (RobStride: calibration, brake, quick move) are None.
    """

    _cache: dict[tuple, "Layouts"] = {}

    def __init__(self, dbc: str, prefix: str):
        db = load_file(dbc)
        names = {m.name for m in db.messages}

        def msg(name: str):
            return db.get_message_by_name(name.replace("CG_", prefix + "_", 1))

        def optional(name: str):
            full = name.replace("CG_", prefix + "_", 1)
            return MessageCodec.of(db.get_message_by_name(full)) if full in names else None

        self.motion = MessageCodec.of(msg("CG_MotionCmd"))
        self.motion_fields = tuple(self.motion.signals[name] for name in ("PosRef", "VelRef", "Kp", "Kd"))
        self.feedback = MessageCodec.of(msg("CG_Feedback"))
        # the type-2 payload from the four values, each by the manual's truncating float_to_uint
        self.feedback_payload = self.feedback.encoder(dict.fromkeys(("Pos", "Vel", "Torque", "Temp"), "truncated"))
        self.device_id = MessageCodec.of(msg("CG_DeviceId"))
        self.stop = MessageCodec.of(msg("CG_Stop"))
        self.set_zero = MessageCodec.of(msg("CG_SetZero"))
        self.set_baud = optional("CG_SetBaud")
        self.fault_warn = MessageCodec.of(msg("CG_FaultWarn"))
        self.calibration = optional("CG_Calibration")
        write, read = msg("CG_ParamWrite"), msg("CG_ParamRead")
        self.index = MessageCodec(write, [write.get_signal_by_name("Index")])
        # a type-18 write of run_mode 7, in cybergear_id.dbc: the type alone does not select it
        self.quick_move = MessageCodec.of(load_file(cg.ID_DBC).get_message_by_name("CG_QuickMove")) \
            if prefix == "CG" else None
        self.params = {}  # index -> (name, index, write codec, read-reply codec)
        for sig in write.signals:
            for index in sig.multiplexer_ids or ():
                self.params[index] = (
                    sig.name, index, MessageCodec(write, [write.get_signal_by_name("Index"), sig]),
                    MessageCodec(read, [read.get_signal_by_name("Index"), read.get_signal_by_name(sig.name)]))

    @classmethod
    def get(cls, dbc: str, prefix: str = "CG") -> "Layouts":
        if (dbc, prefix) not in cls._cache:
            cls._cache[dbc, prefix] = cls(dbc, prefix)
        return cls._cache[dbc, prefix]
