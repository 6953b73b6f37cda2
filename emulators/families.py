"""The rig's own device families, registered in pyproject.toml's ``wheelleg.devices`` group.

Each ``make`` imports its emulator only when called, so listing the families
(``wheelleg emulate --help``) imports no emulator.
"""
from __future__ import annotations

import argparse
from collections.abc import Sequence

from wheelleg.emulators.family import DeviceFamily, int_id


def _command_timeout(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--command-timeout", type=float, default=None, metavar="S",
                        help="zero the output when no command came for S seconds "
                             "(default: hold the last command forever)")


def _cybergear_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--host", type=int_id, default=0x00, metavar="N",
                        help="CAN_MASTER: the host id in 0..127 the motors answer (default 0x00); "
                             "hosts 0x80..0xFF (0xFD, the debugger's) are always answered")
    parser.add_argument("--position-range", choices=("12.5", "4pi"), default="12.5",
                        help="position field range in rad (default: %(default)s)")
    parser.add_argument("--uid", type=int_id, default=None, metavar="UID",
                        help="64-bit MCU unique id sent in type-0 replies")


def _make_cybergear(args: argparse.Namespace, ids: Sequence[int]) -> list:
    from wheelleg.emulators.cybergear import CyberGear
    if args.uid is not None and len(ids) > 1:
        raise ValueError("--uid names one motor; give it with a single --id")
    return [CyberGear(motor_id=i, position_range=args.position_range, uid=args.uid, host_id=args.host)
            for i in ids]


def _make_c620(args: argparse.Namespace, ids: Sequence[int]) -> list:
    from wheelleg.emulators.c620 import C620
    return [C620(esc_id=i, command_timeout_s=args.command_timeout) for i in ids]


def _make_c610(args: argparse.Namespace, ids: Sequence[int]) -> list:
    from wheelleg.emulators.dji import C610
    return [C610(i, command_timeout_s=args.command_timeout) for i in ids]


def _make_gm6020(args: argparse.Namespace, ids: Sequence[int]) -> list:
    from wheelleg.emulators.dji import GM6020
    return [GM6020(i, command_timeout_s=args.command_timeout) for i in ids]


def _damiao_arguments(parser: argparse.ArgumentParser) -> None:
    from wheelleg.emulators.damiao import MODELS
    parser.add_argument("--model", choices=sorted(MODELS), default="DM-J4310-2EC",
                        help="motor model: its PMAX/VMAX/TMAX and motor line (default: %(default)s)")
    parser.add_argument("--master", type=int_id, default=0x00, metavar="N",
                        help="MST_ID, the id every reply goes to (default 0x00)")


def _make_damiao(args: argparse.Namespace, ids: Sequence[int]) -> list:
    from wheelleg.emulators.damiao import Damiao
    return [Damiao(model=args.model, esc_id=i, master_id=args.master) for i in ids]


def _robstride_arguments(parser: argparse.ArgumentParser) -> None:
    from wheelleg.emulators.robstride import MODELS
    parser.add_argument("--model", choices=sorted(MODELS), default="RS01",
                        help="actuator model: its scales, limits and motor line (default: %(default)s)")
    parser.add_argument("--host", type=int_id, default=0x00, metavar="N",
                        help="the host id in 0..127 the motors answer (default 0x00); hosts 0x80..0xFF always")
    parser.add_argument("--uid", type=int_id, default=None, metavar="UID",
                        help="64-bit MCU unique id sent in type-0 replies")


def _make_robstride(args: argparse.Namespace, ids: Sequence[int]) -> list:
    from wheelleg.emulators.robstride import RobStride
    if args.uid is not None and len(ids) > 1:
        raise ValueError("--uid names one motor; give it with a single --id")
    return [RobStride(model=args.model, motor_id=i, uid=args.uid, host_id=args.host) for i in ids]


def _imu_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--imu-period", type=float, default=0.002, metavar="S",
                        help="IMU frame period (default: %(default)s s)")
    parser.add_argument("--seed", type=int, default=0, help="IMU noise seed (default: %(default)s)")


def _make_imu(args: argparse.Namespace, ids: Sequence[int]) -> list:
    import numpy as np

    from wheelleg.emulators.imu import Imu, ImuNoise
    return [Imu(period_s=args.imu_period, noise=ImuNoise(), rng=np.random.default_rng(args.seed))]


CYBERGEAR = DeviceFamily("cybergear", "Xiaomi CyberGear micro-motor (29-bit ids)", ("cybergear.dbc", "cybergear_id.dbc"),
                         (0x7F,), _make_cybergear, _cybergear_arguments, "motor id 0..127 (default 0x7F)")
C620_FAMILY = DeviceFamily("c620", "DJI C620 ESC + M3508 P19", ("c620.dbc",), (1,), _make_c620, _command_timeout,
                           "ESC id 1..8 (default 1)")
C610_FAMILY = DeviceFamily("c610", "DJI C610 ESC + M2006 P36", ("c610.dbc",), (1,), _make_c610, _command_timeout,
                           "ESC id 1..8 (default 1)")
GM6020_FAMILY = DeviceFamily("gm6020", "DJI GM6020 gimbal motor (voltage and current frames)", ("gm6020.dbc",), (1,),
                             _make_gm6020, _command_timeout, "motor id 1..7 (default 1)")
DAMIAO = DeviceFamily("damiao", "Damiao DM-J4310-2EC, DM-J4340-2EC, DM-J8009P-2EC joint motors", ("damiao.dbc",), (1,),
                      _make_damiao, _damiao_arguments, "ESC_ID 1..0x7FE (default 1)")
ROBSTRIDE = DeviceFamily("robstride", "RobStride RS01, RS02, RS03, RS04 actuators (29-bit ids, CyberGear family)",
                         ("robstride_rs01.dbc", "robstride_rs02.dbc", "robstride_rs03.dbc", "robstride_rs04.dbc"),
                         (0x7F,), _make_robstride, _robstride_arguments, "motor id 0..127 (default 0x7F)")
IMU = DeviceFamily("imu", "the rig's IMU (rig.dbc)", ("rig.dbc",), (), _make_imu, _imu_arguments)
