"""The rig's DBC files and the small codecs that read them.

Every byte layout on both buses lives in the ``*.dbc`` files beside this
module; nothing else in the project hard-codes one. This package only loads
them (through cantools) and adds what a DBC cannot say by itself: the
CyberGear fields that live in the 29-bit identifier (``wheelleg.dbc.cybergear``) and
the manual's truncating float-to-uint encoder.

Buses (docs/protocols.md): CAN1 (``CAN1 = "can1"``) carries the wheel ESCs,
the IMU, the remote, SYNC and heartbeat; CAN2 (``CAN2 = "can2"``) carries the
four CyberGear joint motors, SYNC and heartbeat. These two names are the
buses' names everywhere in the project (controller, emulators, traces),
defined here only.

The quadruped (``QUADRUPED_BUS_FILES``) has two buses too, under the same two
names: CAN1 is its bus 0 (front legs' CyberGears, IMU, remote), CAN2 its bus 1
(rear legs' CyberGears); its remote frame is ``quadruped.dbc``'s QuadOperator.
Every robot's buses name their files (``wheelleg.hil.robots.Bus.dbc_files``: these
tables for the rig's own robots, a plug-in robot's own files by path), and
``load_files`` loads any such list.
"""
from __future__ import annotations

import functools
import math
from pathlib import Path

import cantools

from wheelleg.dbc.codec import truncate

DBC_DIR = Path(__file__).resolve().parent
CAN1, CAN2 = "can1", "can2"  # wheels, IMU, remote | CyberGear joints
BUSES = (CAN1, CAN2)
BUS_FILES = {
    CAN1: ("c620.dbc", "rig.dbc"),
    CAN2: ("cybergear.dbc", "rig.dbc"),
}
QUADRUPED_BUS_FILES = {
    CAN1: ("cybergear.dbc", "rig.dbc", "quadruped.dbc"),
    CAN2: ("cybergear.dbc", "rig.dbc"),
}
ROBOT_BUS_FILES = {"wheel-legged": BUS_FILES, "quadruped": QUADRUPED_BUS_FILES}  # the rig's own robots
CYBERGEAR_FILES = {"12.5": "cybergear.dbc", "4pi": "cybergear_4pi.dbc"}


def dbc_path(name: str) -> Path:
    """Path of one DBC file of this package."""
    path = DBC_DIR / name
    if not path.is_file():
        raise FileNotFoundError(f"no DBC file {name!r} in {DBC_DIR}")
    return path


def all_dbc_files() -> list[Path]:
    """Every DBC file the rig ships, sorted by name."""
    return sorted(DBC_DIR.glob("*.dbc"))


@functools.lru_cache(maxsize=None)
def load_file(name: str) -> cantools.database.Database:
    """Load one DBC by file name; a malformed file raises with its name."""
    try:
        return cantools.database.load_file(str(dbc_path(name)))
    except cantools.database.UnsupportedDatabaseFormatError as exc:
        raise ValueError(f"{name}: not a valid DBC file: {exc}") from exc


@functools.lru_cache(maxsize=None)
def load_bus(bus: str, position_range: str = "12.5", robot: str = "wheel-legged") -> cantools.database.Database:
    """One cantools database holding every message that can appear on ``bus`` of ``robot``.

    ``bus`` is ``"can1"`` (wheels) or ``"can2"`` (joints) of the wheel-legged
    robot, bus 0 or bus 1 of the quadruped (``robot="quadruped"``);
    ``position_range`` picks the CyberGear position scale (``"12.5"`` default or ``"4pi"``).
    """
    files = ROBOT_BUS_FILES.get(robot)
    if files is None:
        raise ValueError(f"unknown robot {robot!r}; expected one of {sorted(ROBOT_BUS_FILES)}")
    if bus not in files:
        raise ValueError(f"unknown bus {bus!r}; expected one of {sorted(files)}")
    return load_files(tuple(CYBERGEAR_FILES[position_range] if n == "cybergear.dbc" else n for n in files[bus]))


def resolve(file: str | Path) -> Path:
    """A bus's DBC file: a bare name is one of this package's (``dbc_path``), a path is taken as it is."""
    return dbc_path(file) if isinstance(file, str) and "/" not in file else Path(file)


@functools.lru_cache(maxsize=None)
def load_files(files: tuple[str | Path, ...]) -> cantools.database.Database:
    """One cantools database of ``files`` (``resolve``: the rig's by name, a plug-in robot's by path);
    a missing or malformed file raises one line with its name."""
    db = cantools.database.Database()
    for file in files:
        path = resolve(file)
        try:
            db.add_dbc_file(str(path))
        except OSError as exc:
            raise FileNotFoundError(f"no DBC file {path}: {exc.strerror}") from None
        except cantools.database.UnsupportedDatabaseFormatError as exc:
            raise ValueError(f"{path}: not a valid DBC file: {exc}") from None
    return db


def truncating_raw(signal, value: float) -> int:
    """Raw value of an unsigned, ranged cantools signal the CyberGear way (``codec.truncate``).

    The manual's ``float_to_uint`` clamps to [min, max] and truncates
    ``(x - min) * (2^bits - 1) / (max - min)``; cantools would round. NaN
    encodes as the minimum (the clamp of a comparison that is always false).
    """
    return truncate(signal.minimum, signal.maximum, (1 << signal.length) - 1, value)


def is_finite_number(value) -> bool:
    """True for an int or a finite float (decoded signals can carry NaN/inf)."""
    return isinstance(value, int) or (isinstance(value, float) and math.isfinite(value))
