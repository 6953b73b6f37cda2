"""Write the firmware's generated configuration header from the Python program's numbers.

    python -m wheelleg.controller.design.firmware_config [--check]

The C firmware (``firmware/``, docs/firmware.md) runs the same robot with the same
tuning as ``wheelleg.controller``: every number it needs comes from here, never
typed twice. ``firmware/app/wl_config.h`` gets

- every numeric constant of ``controller/constants.py`` (``WL_C_*``) and of
  ``controller/params.py`` (``WL_P_*``), float32 literals (times in s also as doubles,
  ``NAME_D``); a tuple's items as ``NAME_0``, ``NAME_1``, ...; the joints, wheels and
  devices as tables;
- the offline thresholds of ``controller/detect.py`` (``WL_DETECT_*``);
- the layout of every frame the firmware reads or writes, from the DBC files
  (``WL_SIG_*`` signal initialisers, ``WL_ID_*``, ``WL_DLC_*``), so the C codecs
  derive from ``dbc/`` like the Python ones;
- ``firmware/tests/vectors.h``: five-bar and LQR values computed by the Python code
  that ``make test`` compares the C math with.

``--check`` fails (exit 1) when either file differs from what this script writes
now (a test runs it), so the two programs cannot silently drift apart.
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from wheelleg.controller import constants as C
from wheelleg.controller import detect
from wheelleg.controller import fivebar
from wheelleg.controller import lqr
from wheelleg.controller import params as P
from wheelleg.dbc import CAN1, CAN2, load_bus, load_file

FIRMWARE_DIR = Path(__file__).resolve().parents[2] / "firmware"
CONFIG_PATH = FIRMWARE_DIR / "app" / "wl_config.h"
VECTORS_PATH = FIRMWARE_DIR / "tests" / "vectors.h"

# (bus, message, signals) the firmware reads or writes: (DBC message name, C name)
MESSAGES = (
    (CAN1, "SYNC", "SYNC"), (CAN1, "IMU_Orientation", "IMU_QUAT"), (CAN1, "IMU_Gyro", "IMU_GYRO"),
    (CAN1, "IMU_Accel", "IMU_ACCEL"), (CAN1, "Operator", "OPERATOR"), (CAN1, "Heartbeat", "HEARTBEAT"),
    (CAN1, "C620_Cmd_1_4", "C620_CMD"), (CAN1, "C620_Feedback_1", "C620_FB"),
    (CAN2, "CG_MotionCmd", "CG_MOTION"), (CAN2, "CG_Feedback", "CG_FEEDBACK"), (CAN2, "CG_Stop", "CG_STOP"),
    (CAN2, "CG_Enable", "CG_ENABLE"), (CAN2, "CG_ParamWrite", "CG_PARAM_WRITE"),
    (CAN2, "CG_FaultWarn", "CG_FAULT_WARN"),
)
# names of times (s) the firmware also needs in double: its phase timers add the period in double
# and compare as the Python program does, so a phase ends on the same tick (0.4f is not 0.4)
TIMER_SUFFIXES = ("_S", "_TIME", "_TIMEOUT")
ID_MESSAGES = (("CG_Id_Request", "CGID_REQ"), ("CG_Id_Motion", "CGID_MOTION"), ("CG_Id_Reply", "CGID_REPLY"))


def c_float(value: float) -> str:
    """A float32 literal of ``value`` (shortest repr of the double, rounded by the compiler)."""
    if not math.isfinite(value):
        return "(1.0f / 0.0f)" if value > 0 else "(-1.0f / 0.0f)"
    text = repr(float(value))
    if "e" not in text and "." not in text:
        text += ".0"
    return f"{text}f"


def _numbers(module, prefix: str) -> list[str]:
    """#defines of every public numeric (or numeric tuple) module-level name of ``module``."""
    lines = []
    for name, value in vars(module).items():
        if name.startswith("_") or not name.isupper():
            continue
        if isinstance(value, bool):
            continue
        if isinstance(value, int):
            lines.append(f"#define {prefix}{name} {value}")
        elif isinstance(value, float):
            lines.append(f"#define {prefix}{name} {c_float(value)}")
            if name.endswith(TIMER_SUFFIXES):  # the phase timers compare a double sum, as the Python
                lines.append(f"#define {prefix}{name}_D {float(value)!r}")
        elif isinstance(value, tuple) and value and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                        for v in value):
            for i, v in enumerate(value):
                lines.append(f"#define {prefix}{name}_{i} {c_float(float(v))}")
    return lines


def c_double(value: float) -> str:
    """A double literal of ``value`` (HUGE_VAL for an open end)."""
    if not math.isfinite(value):
        return "HUGE_VAL" if value > 0 else "(-HUGE_VAL)"
    return repr(float(value))


def _signal(message, signal) -> str:
    """A ``wl_signal_t`` initialiser of one DBC signal: {big, shift, bits, signed, scale, offset, min, max},
    the scaling and range in double as the DBC has them (the codec checks the range as the Python one
    does: 32767 x 0.001f is above 32.767f, 32767 x 0.001 is not)."""
    bits = signal.length
    if signal.byte_order == "little_endian":
        big, shift = 0, signal.start
    else:
        msb = 8 * (signal.start // 8) + 7 - signal.start % 8
        big, shift = 1, 8 * message.length - msb - bits
    low = -math.inf if signal.minimum is None else signal.minimum
    high = math.inf if signal.maximum is None else signal.maximum
    return (f"{{{big}, {shift}, {bits}, {int(signal.is_signed)}, {c_double(signal.scale)}, {c_double(signal.offset)}, "
            f"{c_double(low)}, {c_double(high)}}}")


def _c_name(text: str) -> str:
    return "".join(ch if ch.isalnum() else "_" for ch in text).upper()


def _layouts() -> list[str]:
    lines = []
    dbs = {CAN1: load_bus(CAN1), CAN2: load_bus(CAN2)}
    for bus, name, cname in MESSAGES:
        message = dbs[bus].get_message_by_name(name)
        lines.append(f"#define WL_ID_{cname} 0x{message.frame_id:X}u")
        lines.append(f"#define WL_DLC_{cname} {message.length}")
        for signal in message.signals:
            lines.append(f"#define WL_SIG_{cname}_{_c_name(signal.name.split(' ')[0])} {_signal(message, signal)}")
    ids = load_file("cybergear_id.dbc")
    for name, cname in ID_MESSAGES:
        message = ids.get_message_by_name(name)
        for signal in message.signals:
            lines.append(f"#define WL_{cname}_{_c_name(signal.name)} {_signal(message, signal)}")
    return lines


def _tables() -> list[str]:
    lines = [f"#define WL_N_JOINTS {len(C.JOINTS)}", f"#define WL_N_WHEELS {len(C.WHEELS)}",
             f"#define WL_N_DEVICES {len(C.DEVICES)}"]
    # {motor id, leg (0 left, 1 right), hip (0 A front, 1 E rear), sign, stop angle}
    rows = ", ".join(f"{{{j.motor_id}, {0 if j.leg == 'left' else 1}, {0 if j.hip == 'A' else 1}, {j.sign}, "
                     f"{c_float(j.stop)}}}" for j in C.JOINTS)
    lines.append(f"#define WL_JOINT_TABLE {{{rows}}}")
    rows = ", ".join(f"{{{w.esc_id}, {0 if w.leg == 'left' else 1}, {w.forward_sign}}}" for w in C.WHEELS)
    lines.append(f"#define WL_WHEEL_TABLE {{{rows}}}")
    names = ", ".join(f'"{name}"' for name in C.DEVICES)
    lines.append(f"#define WL_DEVICE_NAMES {{{names}}}")
    # {offline after (us), warning level, needed for balance}
    rows = ", ".join(f"{{{round(r.offline_after_s * 1e6)}u, {r.warning_level}, {int(r.needed_for_balance)}}}"
                     for r in detect.RULES)
    lines.append(f"#define WL_DETECT_TABLE {{{rows}}}")
    lines.append(f"#define WL_MASS_AT_AXLE {c_float(fivebar.MASS_AT_AXLE)}")
    return lines


def render_config() -> str:
    head = ["/* The firmware's configuration: generated by python -m wheelleg.controller.design.firmware_config;",
            " * do not edit. Every number from controller/constants.py (WL_C_), controller/params.py (WL_P_),",
            " * controller/detect.py (WL_DETECT_TABLE) and every frame layout from dbc/ (WL_SIG_, WL_ID_, WL_DLC_).",
            " * WL_SIG_ initialisers: {big-endian, shift in the payload integer, bits, signed, scale, offset,",
            " * minimum, maximum} (the payload integer: little-endian bytes, or big-endian for a big-endian signal;",
            " * scaling and range in double, as the DBC gives them). */",
            "#ifndef WL_CONFIG_H", "#define WL_CONFIG_H", "", "/* controller/constants.py */"]
    body = _numbers(C, "WL_C_") + ["", "/* controller/params.py */"] + _numbers(P, "WL_P_")
    body += ["", "/* tables: joints {motor id, leg, hip, sign, stop}, wheels {esc id, leg, forward sign},",
             " * detect rules {offline after us, warning level, needed for balance} */"] + _tables()
    body += ["", "/* frame layouts (dbc/) */"] + _layouts()
    return "\n".join(head + body + ["", "#endif", ""])


def render_vectors() -> str:
    """Test vectors the C unit tests compare with: Python's five-bar and LQR at a few points."""
    lines = ["/* Test vectors computed by the Python program: generated by",
             " * python -m wheelleg.controller.design.firmware_config; do not edit. */",
             "#ifndef WL_VECTORS_H", "#define WL_VECTORS_H", "",
             "/* forward kinematics: {phi1, phi4, L0, phi0, phi2, j11, j12, j21, j22} */",
             "static const double FK_VECTORS[][9] = {"]
    for phi1, phi4 in ((2.2, 0.9), (2.0, 1.1), (1.9, 1.25), (2.5, 0.6), (1.7, 1.45)):
        k = fivebar.forward_kinematics(phi1, phi4)
        (j11, j12), (j21, j22) = k.jacobian
        values = (phi1, phi4, k.L0, k.phi0, k.phi2, j11, j12, j21, j22)
        lines.append("    {" + ", ".join(repr(float(v)) for v in values) + "},")
    lines += ["};", "", "/* inverse kinematics: {L0, phi0, phi1, phi4} */", "static const double IK_VECTORS[][4] = {"]
    for L0, phi0 in ((0.12, math.pi / 2), (0.17, 1.4), (0.22, 1.75), (0.26, math.pi / 2)):
        phi1, phi4 = fivebar.inverse_kinematics(L0, phi0)
        lines.append("    {" + ", ".join(repr(float(v)) for v in (L0, phi0, phi1, phi4)) + "},")
    lines += ["};", "", "/* LQR gains: {L0, K[0][0..8], K[1][0..8]} (lqr.gain_matrix, clamped L0) */",
              "static const double LQR_VECTORS[][19] = {"]
    for L0 in (0.05, 0.12, 0.17, 0.2, 0.26, 0.3):
        k = lqr.gain_matrix(L0)
        lines.append("    {" + ", ".join(repr(float(v)) for v in (L0, *k[0], *k[1])) + "},")
    lines += ["};", "", "/* balance lean: {hold torque, L0, weight ratio, theta} */",
              "static const double LEAN_VECTORS[][4] = {"]
    for hold, L0, ratio in ((0.3, 0.17, 1.0), (-0.5, 0.22, 1.2), (2.0, 0.12, 0.8)):
        theta = lqr.balance_lean(hold, L0, P.BALANCE_LEAN_LIMIT, ratio)
        lines.append("    {" + ", ".join(repr(float(v)) for v in (hold, L0, ratio, theta)) + "},")
    lines += ["};", "", "#endif", ""]
    return "\n".join(lines)


OUTPUTS = ((CONFIG_PATH, render_config), (VECTORS_PATH, render_vectors))


def stale() -> list[str]:
    """The generated files that differ from a fresh render (their paths); [] when current."""
    return [str(path) for path, render in OUTPUTS if not path.is_file() or path.read_text() != render()]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m wheelleg.controller.design.firmware_config",
                                     description=__doc__.split("\n")[0])
    parser.add_argument("--check", action="store_true", help="do not write; exit 1 if a generated file is stale")
    args = parser.parse_args(argv)
    if args.check:
        problems = stale()
        for path in problems:
            print(f"stale generated firmware file: {path}", file=sys.stderr)
        if problems:
            print("run: python -m wheelleg.controller.design.firmware_config", file=sys.stderr)
            return 1
        print("firmware configuration is up to date")
        return 0
    for path, render in OUTPUTS:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(render())
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
