"""The CyberGear's stored parameter table, 0x0000-0x302F (docs/protocols.md, parameter table).

The manual's table (section 3.3.3, the debugger's parameter list): function
code, name, type, access, range and the value a motor showed (its "current
value, for reference"), which the emulator takes as its power-up value. Names
are the manual's, made DBC-safe (``vBus(mv)`` -> ``vBus_mv``); they are the
signal names of ``CG_ParamTable`` and ``CG_ConfigRead``/``CG_ConfigWrite`` in
the CyberGear DBC. The 0x70xx runtime parameters (types 17/18) are a
different table, in the emulator itself.
"""
from __future__ import annotations

from dataclasses import dataclass

STRING, CONFIG, READ_WRITE, READ_ONLY = "string", "config", "rw", "ro"


@dataclass(frozen=True)
class Entry:
    """One row: index (function code), DBC-safe name, kind (str/u8/u16/i16/u32/i32/f32), access."""

    index: int
    name: str
    kind: str
    access: str  # "rw"; "config" (the manual's "configuration"); "ro" (read only, and its "set up" rows:
    # set by calibration or a type-7 id change, never by a type-8 write)
    default: object
    lo: float | None = None
    hi: float | None = None

    @property
    def writable(self) -> bool:
        """Type 8 may change it: the manual's read/write and configuration rows, never the read-only ones."""
        return self.kind != "str" and self.access in (READ_WRITE, CONFIG)


UNPROGRAMMED = "\xff" * 16  # Name and BarCode of a fresh motor: erased flash, 16 0xFF bytes

TABLE: tuple[Entry, ...] = (
    Entry(0x0000, "Name", "str", READ_WRITE, UNPROGRAMMED),
    Entry(0x0001, "BarCode", "str", READ_WRITE, UNPROGRAMMED),
    Entry(0x1000, "BootCodeVersion", "str", READ_ONLY, "0.1.5"),
    Entry(0x1001, "BootBuildDate", "str", READ_ONLY, "Mar 16 2022"),
    Entry(0x1002, "BootBuildTime", "str", READ_ONLY, "20:22:09"),
    Entry(0x1003, "AppCodeVersion", "str", READ_ONLY, "0.1.5"),
    Entry(0x1004, "AppGitVersion", "str", READ_ONLY, "7b844b0fM"),
    Entry(0x1005, "AppBuildDate", "str", READ_ONLY, "Apr 14 2022"),
    Entry(0x1006, "AppBuildTime", "str", READ_ONLY, "20:30:22"),
    Entry(0x1007, "AppCodeName", "str", READ_ONLY, "dog_motor"),
    Entry(0x2000, "echoPara1", "u16", CONFIG, 5, 5, 74),
    Entry(0x2001, "echoPara2", "u16", CONFIG, 5, 5, 74),
    Entry(0x2002, "echoPara3", "u16", CONFIG, 5, 5, 74),
    Entry(0x2003, "echoPara4", "u16", CONFIG, 5, 5, 74),
    Entry(0x2004, "echoFreHz", "u32", READ_WRITE, 500, 1, 10000),
    Entry(0x2005, "MechOffset", "f32", READ_ONLY, 4.619583, -7, 7),
    Entry(0x2006, "MechPos_init", "f32", READ_WRITE, 4.52, -50, 50),
    Entry(0x2007, "limit_torque", "f32", READ_WRITE, 12.0, 0, 12),
    Entry(0x2008, "I_FW_MAX", "f32", READ_WRITE, 0.0, 0, 33),
    Entry(0x2009, "motor_index", "u8", READ_ONLY, 1, 0, 20),
    Entry(0x200A, "CAN_ID", "u8", READ_ONLY, 1, 0, 127),  # live: the motor id (type 7 changes it)
    Entry(0x200B, "CAN_MASTER", "u8", READ_ONLY, 0, 0, 127),  # live: the host id it answers
    Entry(0x200C, "CAN_TIMEOUT", "u32", READ_WRITE, 0, 0, 100000),
    Entry(0x200D, "motorOverTemp", "i16", READ_WRITE, 800, 0, 1500),
    Entry(0x200E, "overTempTime", "u32", READ_WRITE, 20000, 1000, 1000000),
    Entry(0x200F, "GearRatio", "f32", READ_WRITE, 7.75, 1, 64),
    Entry(0x2010, "Tq_caliType", "u8", READ_WRITE, 1, 0, 1),
    Entry(0x2011, "cur_filt_gain", "f32", READ_WRITE, 0.9, 0, 1),
    Entry(0x2012, "cur_kp", "f32", READ_WRITE, 0.025, 0, 200),
    Entry(0x2013, "cur_ki", "f32", READ_WRITE, 0.0258, 0, 200),
    Entry(0x2014, "spd_kp", "f32", READ_WRITE, 2.0, 0, 200),
    Entry(0x2015, "spd_ki", "f32", READ_WRITE, 0.021, 0, 200),
    Entry(0x2016, "loc_kp", "f32", READ_WRITE, 30.0, 0, 200),
    Entry(0x2017, "spd_filt_gain", "f32", READ_WRITE, 0.1, 0, 1),
    Entry(0x2018, "limit_spd", "f32", READ_WRITE, 2.0, 0, 200),
    Entry(0x2019, "limit_cur", "f32", READ_WRITE, 23.0, 0, 23),
    Entry(0x3000, "timeUse0", "u16", READ_ONLY, 5),
    Entry(0x3001, "timeUse1", "u16", READ_ONLY, 0),
    Entry(0x3002, "timeUse2", "u16", READ_ONLY, 10),
    Entry(0x3003, "timeUse3", "u16", READ_ONLY, 0),
    Entry(0x3004, "encoderRaw", "u16", READ_ONLY, 11396),
    Entry(0x3005, "mcuTemp", "i16", READ_ONLY, 337),
    Entry(0x3006, "motorTemp", "i16", READ_ONLY, 333),  # live: winding temperature * 10
    Entry(0x3007, "vBus_mv", "u16", READ_ONLY, 24195),  # live
    Entry(0x3008, "adc1Offset", "i32", READ_ONLY, 2084),
    Entry(0x3009, "adc2Offset", "i32", READ_ONLY, 2084),
    Entry(0x300A, "adc1Raw", "u16", READ_ONLY, 1232),
    Entry(0x300B, "adc2Raw", "u16", READ_ONLY, 1212),
    Entry(0x300C, "VBUS", "f32", READ_ONLY, 24.195),  # live
    Entry(0x300D, "cmdId", "f32", READ_ONLY, 0.0),
    Entry(0x300E, "cmdIq", "f32", READ_ONLY, 0.0),
    Entry(0x300F, "cmdlocref", "f32", READ_ONLY, 0.0),
    Entry(0x3010, "cmdspdref", "f32", READ_ONLY, 0.0),
    Entry(0x3011, "cmdTorque", "f32", READ_ONLY, 0.0),
    Entry(0x3012, "cmdPos", "f32", READ_ONLY, 0.0),
    Entry(0x3013, "cmdVel", "f32", READ_ONLY, 0.0),
    Entry(0x3014, "rotation", "i16", READ_ONLY, 1),  # live
    Entry(0x3015, "modPos", "f32", READ_ONLY, 4.363409),
    Entry(0x3016, "mechPos", "f32", READ_ONLY, 0.777679),  # live
    Entry(0x3017, "mechVel", "f32", READ_ONLY, 0.036618),  # live
    Entry(0x3018, "elecPos", "f32", READ_ONLY, 4.714761),
    Entry(0x3019, "ia", "f32", READ_ONLY, 0.0),
    Entry(0x301A, "ib", "f32", READ_ONLY, 0.0),
    Entry(0x301B, "ic", "f32", READ_ONLY, 0.0),
    Entry(0x301C, "tick", "u32", READ_ONLY, 31600),
    Entry(0x301D, "phaseOrder", "u8", READ_ONLY, 0),
    Entry(0x301E, "iqf", "f32", READ_ONLY, 0.0),  # live
    Entry(0x301F, "boardTemp", "i16", READ_ONLY, 359),
    Entry(0x3020, "iq", "f32", READ_ONLY, 0.0),  # live
    Entry(0x3021, "id", "f32", READ_ONLY, 0.0),
    Entry(0x3022, "faultSta", "u32", READ_ONLY, 0),
    Entry(0x3023, "warnSta", "u32", READ_ONLY, 0),
    Entry(0x3024, "drv_fault", "u16", READ_ONLY, 0),
    Entry(0x3025, "drv_temp", "i16", READ_ONLY, 48),
    Entry(0x3026, "Uq", "f32", READ_ONLY, 0.0),
    Entry(0x3027, "Ud", "f32", READ_ONLY, 0.0),
    Entry(0x3028, "dtc_u", "f32", READ_ONLY, 0.0),
    Entry(0x3029, "dtc_v", "f32", READ_ONLY, 0.0),
    Entry(0x302A, "dtc_w", "f32", READ_ONLY, 0.0),
    Entry(0x302B, "v_bus", "f32", READ_ONLY, 24.195),  # live
    Entry(0x302C, "v_ref", "f32", READ_ONLY, 0.0),
    Entry(0x302D, "torque_fdb", "f32", READ_ONLY, 0.0),  # live
    Entry(0x302E, "rated_i", "f32", READ_ONLY, 8.0),
    Entry(0x302F, "limit_i", "f32", READ_ONLY, 27.0),
)
BY_INDEX = {e.index: e for e in TABLE}
