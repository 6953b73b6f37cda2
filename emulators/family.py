"""Device families: what ``wheelleg emulate NAME`` and a robot's ``Device.kind`` name.

A family is one kind of CAN device (a motor series, an ESC, an IMU): its DBC
files, its default ids, the options ``wheelleg emulate`` takes for it and how
it builds its emulated devices. Families are found the way python-can finds
its interfaces (``can.interface``): an installed package lists each one under
the ``wheelleg.devices`` entry-point group, the name of the entry being the
family's name and its value a ``DeviceFamily`` object::

    [project.entry-points."wheelleg.devices"]
    mymotor = "mypackage.family:FAMILY"

The rig's own families register themselves the same way (pyproject.toml). A
broken entry (it does not import, or is not a ``DeviceFamily``, or its name
differs from the entry's) is one warning line naming its package; the other
families still load.
"""
from __future__ import annotations

import argparse
import importlib.metadata
import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

GROUP = "wheelleg.devices"

log = logging.getLogger(__name__)


def _no_arguments(parser: argparse.ArgumentParser) -> None:
    """A family without options of its own."""


@dataclass(frozen=True)
class DeviceFamily:
    """One kind of emulated CAN device.

    ``make(args, ids)`` returns the devices ``wheelleg emulate NAME`` serves
    (``args``: the parsed options, those of ``add_arguments`` included; ``ids``:
    the ``--id`` values, or ``default_ids``); it raises ValueError with a
    one-line message for a bad id or option. ``default_ids`` empty: the family
    has no ids (``--id`` is refused).
    """

    name: str
    summary: str
    dbc_files: tuple[str, ...]
    default_ids: tuple[int, ...]
    make: Callable[[argparse.Namespace, Sequence[int]], list]
    add_arguments: Callable[[argparse.ArgumentParser], None] = field(default=_no_arguments)
    id_help: str = "device id (decimal or 0x hex); repeat for several devices in one process"


def _load(entry) -> DeviceFamily:
    family = entry.load()
    if not isinstance(family, DeviceFamily):
        raise TypeError(f"{entry.value} is a {type(family).__name__}, not a DeviceFamily")
    if family.name != entry.name:
        raise ValueError(f"entry {entry.name!r} holds the family {family.name!r}")
    return family


def families() -> dict[str, DeviceFamily]:
    """Every installed family by name; a broken entry is warned about (one line) and skipped."""
    found: dict[str, DeviceFamily] = {}
    for entry in importlib.metadata.entry_points(group=GROUP):
        package = entry.dist.name if entry.dist is not None else "an unknown package"
        try:
            family = _load(entry)
        except Exception as exc:  # noqa: BLE001 - a plug-in must not break the rig
            log.warning("device family %r from %s skipped: %s: %s", entry.name, package, type(exc).__name__, exc)
            continue
        if family.name in found:
            log.warning("device family %r from %s skipped: the name is taken", family.name, package)
            continue
        found[family.name] = family
    return dict(sorted(found.items()))


def family(name: str) -> DeviceFamily:
    """The installed family ``name``; ValueError naming the installed ones when there is none."""
    known = families()
    if name not in known:
        raise ValueError(f"no device family {name!r}; installed: {', '.join(known) or 'none'}")
    return known[name]


def int_id(text: str) -> int:
    """An id on the command line: decimal or 0x hex."""
    return int(text, 0)
