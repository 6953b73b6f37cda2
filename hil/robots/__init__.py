"""The robots the rig serves, as installed plug-ins: the ``wheelleg.robots`` entry-point group.

As python-can finds third-party interfaces (the ``can.interface`` entry
points), the rig finds robots: a package registers its ``Robot`` under
``[project.entry-points."wheelleg.robots"]`` (``NAME = "module:ATTRIBUTE"``),
and ``pip install`` of that package makes the robot known to every command.
The rig's own two robots register themselves the same way in its
pyproject.toml. ``BUILTIN`` names them again, as the fallback for a rig whose
package metadata lacks them (a source tree on ``sys.path`` that was never
installed, or an editable install made before the group existed): the rig
must always know its own robots, and the table costs two lines.

A plug-in is loaded when first asked for. A broken one (its module does not
import, its entry point is no ``Robot`` or names another robot, its name is
taken) is one ``RobotPluginWarning`` line naming its package, and it is left
out; the other robots still work. The wheel-legged robot is ``DEFAULT``:
every command that takes ``--robot`` (or a ``ROBOT/SCENARIO`` name) means it
when none is given.

A ``Robot`` says everything the rig needs to run one: its buses with their
devices, CAN ids and DBC files, its MuJoCo model, its scenarios, its
controller program and control period, the plant overrides it honours and the
three factories the rig calls (physics, plant, in-process controller node).
The rig itself (hil/run/rig.py) names no robot.
"""
from __future__ import annotations

import argparse
import functools
import importlib
import importlib.metadata
import json
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import cantools

from wheelleg import dbc

GROUP = "wheelleg.robots"
DISTRIBUTION = "wheelleg-hil"  # the rig's own package: its robots win a name clash
DEFAULT = "wheel-legged"
BUILTIN = {  # the fallback when the rig's metadata lacks its own entry points (see above)
    "wheel-legged": "wheelleg.hil.robots.wheel_legged:ROBOT",
    "quadruped": "wheelleg.hil.robots.quadruped:ROBOT",
}


class RobotPluginWarning(UserWarning):
    """A robot plug-in that cannot be used: one line naming its package; the rest of the rig works."""


@dataclass(frozen=True)
class Device:
    """One CAN node of a robot: its name (the MJCF joint for a motor), kind and CAN id (None: fixed ids)."""

    name: str
    kind: str  # "cybergear" | "c620" | "imu" | "remote"
    can_id: int | None = None


@dataclass(frozen=True)
class Bus:
    """One CAN bus of a robot: its role (``wheelleg.dbc.CAN1``/``CAN2``) and the devices on it."""

    role: str
    summary: str
    devices: tuple[Device, ...]
    dbc_files: tuple[str | Path, ...]  # every layout on it: a bare name is one of the rig's dbc/, a path a plug-in's


@dataclass(frozen=True)
class Robot:
    """A registered robot. Factories (all called by the rig, never by the robot's controller):

    - ``build_physics(terrain, timestep_s, overrides) -> physics``: its MuJoCo world
      (``start(physics)`` of its scenarios poses it; ``ground_truth()`` feeds /sim/state);
    - ``build_plant(physics, buses, rng, plant_config) -> plant``: its emulated devices,
      ``buses`` role -> plant-side ``can.BusABC``; the plant has ``nodes`` (role ->
      ``DeviceNode``), ``devices``, ``remote`` and ``step(now_s)``;
    - ``build_controller(buses, sync, period_s) -> node``: its controller on ``buses``
      (role -> ``can.BusABC``), with ``service()``, ``now()``, ``buses``, ``ticks``,
      ``last_result`` (``.debug``: a dict, maybe empty), ``run(stop)``, ``disable()`` and
      ``controller``, the program without I/O (``on_frame(msg, bus, now_s)``, ``tick(tick, now_s)``:
      what replay feeds a robot's log in free-run mode).
    """

    name: str
    summary: str
    buses: tuple[Bus, ...]
    model_dir: Path  # its MJCF (robot.xml, scene.xml), attached to every trace
    scenario_modules: tuple[str, ...]  # modules with a SCENARIOS tuple
    controller_program: str  # the module `python -m` runs on the robot: add_arguments(parser), main(args)
    controller_params: str  # the module whose upper-case names are the controller's tuning
    control_period_s: float
    build_physics: Callable
    build_plant: Callable
    build_controller: Callable
    sim_state_fields: dict[str, str]  # /sim/state fields its ground truth always has, name -> unit
    mode_names: dict[int, str]  # the heartbeat's Mode values (rig.dbc Heartbeat) -> its controller's mode names
    offline_bits: tuple[str, ...]  # the heartbeat's OfflineMask: bit i -> the device (or group) it stands for
    debug_schema: dict | None = None  # JSON Schema of /controller/debug, None: no debug records
    plant_override_keys: frozenset | None = None  # plant overrides it honours; None: every key

    @property
    def roles(self) -> tuple[str, ...]:
        return tuple(bus.role for bus in self.buses)

    def databases(self) -> dict[str, cantools.database.Database]:
        """Role -> the cantools database of that bus (its ``Bus.dbc_files``)."""
        return {bus.role: dbc.load_files(bus.dbc_files) for bus in self.buses}

    def dbc_paths(self) -> list[Path]:
        """Every DBC file of its buses, once each (attached to every trace of it)."""
        return list(dict.fromkeys(dbc.resolve(f) for bus in self.buses for f in bus.dbc_files))

    def model_files(self) -> list[Path]:
        return sorted(self.model_dir.glob("*.xml"))

    def params_json(self) -> str:
        """Its controller's tuning (every upper-case name of its params module) as sorted JSON."""
        params = importlib.import_module(self.controller_params)
        return json.dumps({k: v for k, v in vars(params).items() if k.isupper()}, sort_keys=True, default=repr)

    def check_overrides(self, overrides: dict) -> None:
        """ValueError (one line) for a plant override this robot's plant does not honour."""
        if self.plant_override_keys is None:
            return
        unknown = sorted(set(overrides) - self.plant_override_keys)
        if unknown:
            raise ValueError(f"plant override {', '.join(unknown)} is not modelled for the {self.name} robot; "
                             f"it takes {', '.join(sorted(self.plant_override_keys)) or 'none'}")


@dataclass(frozen=True)
class Entry:
    """One registered robot before it is loaded: its name, ``module:attribute`` and the package it came from."""

    name: str
    value: str
    package: str  # distribution name
    version: str | None  # None: the rig's own, looked up when asked (``origin``)

    @property
    def origin(self) -> str:
        return f"{self.package} {self.version or _own_version()}"

    def load(self) -> "Robot":
        """Its ``Robot``; ``PluginError`` (one line naming the package) when it cannot be had."""
        module, _, attribute = self.value.partition(":")
        try:
            robot = importlib.import_module(module)
            for part in filter(None, attribute.split(".")):
                robot = getattr(robot, part)
        except Exception as exc:  # noqa: BLE001 - any failure of a third party's import is its package's
            raise PluginError(f"robot plug-in {self.name!r} of package {self.origin}: cannot load {self.value}: "
                              f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}") from None
        if not isinstance(robot, Robot):
            raise PluginError(f"robot plug-in {self.name!r} of package {self.origin}: {self.value} is a "
                              f"{type(robot).__name__}, not a wheelleg.hil.robots.Robot")
        if robot.name != self.name:
            raise PluginError(f"robot plug-in {self.name!r} of package {self.origin}: {self.value} is the robot "
                              f"{robot.name!r}; the entry point's name must be the robot's")
        return robot


class PluginError(KeyError):
    """A robot that is registered but cannot be used (``Entry.load``); a KeyError, as an unknown name is."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0])


def _warn(message: str) -> None:
    warnings.warn(message, RobotPluginWarning, stacklevel=2)


@functools.cache
def _own_version() -> str:
    try:
        return importlib.metadata.version(DISTRIBUTION)
    except importlib.metadata.PackageNotFoundError:
        return "(source tree)"


@functools.cache
def entries() -> dict[str, Entry]:
    """Name -> ``Entry`` of every installed robot (the group's entry points, then ``BUILTIN`` for what they lack).

    A name two packages register is kept for the rig's own package, else the first package by name,
    and warned about once (``RobotPluginWarning``)."""
    found: dict[str, list[Entry]] = {}
    for point in importlib.metadata.entry_points(group=GROUP):
        dist = point.dist
        package, version = (dist.metadata["Name"], dist.version) if dist is not None else ("?", "?")
        found.setdefault(point.name, []).append(Entry(point.name, point.value, package, version))
    for name, value in BUILTIN.items():
        if not any(e.package == DISTRIBUTION for e in found.get(name, ())):
            found.setdefault(name, []).insert(0, Entry(name, value, DISTRIBUTION, None))
    table = {}
    for name, candidates in found.items():
        ranked = sorted(candidates, key=lambda e: (e.package != DISTRIBUTION, e.package.lower()))
        table[name] = ranked[0]
        for other in ranked[1:]:
            if other.package != ranked[0].package:
                _warn(f"robot plug-in {name!r} of package {other.origin} is ignored: "
                      f"the name is taken by package {ranked[0].origin}")
    return table


_LOADED: dict[str, Robot] = {}
_BROKEN: dict[str, str] = {}  # name -> why (warned once)


def reset() -> None:
    """Forget the robots found and loaded: the next call looks at the installed packages again
    (after a package was installed or removed in this process)."""
    entries.cache_clear()
    _LOADED.clear()
    _BROKEN.clear()


def names() -> tuple[str, ...]:
    """Every registered robot, the default first (broken ones too: ``get`` says what is wrong with one)."""
    table = entries()
    return (DEFAULT, *sorted(n for n in table if n != DEFAULT))


def get(name: str | None = None) -> Robot:
    """The registered robot ``name`` (None: the default); KeyError (one line) for an unknown or broken one."""
    name = DEFAULT if name is None else name
    robot = _LOADED.get(name)
    if robot is not None:
        return robot
    # the rig's own robots keep their names whatever else is installed: no need to look at the packages
    entry = Entry(name, BUILTIN[name], DISTRIBUTION, None) if name in BUILTIN else entries().get(name)
    if entry is None:
        raise KeyError(f"no robot {name!r}; known: {', '.join(names())}")
    try:
        robot = _LOADED[name] = entry.load()
    except PluginError as exc:
        _warn_once(name, str(exc))
        raise
    return robot


def warn_broken(name: str, why: str) -> None:
    """One ``RobotPluginWarning`` line for the robot ``name`` whose ``why`` fails, naming its package (once)."""
    _warn_once(name, f"robot plug-in {name!r} of package {origin(name)}: {why.splitlines()[0]}")


def _warn_once(name: str, message: str) -> None:
    if name not in _BROKEN:
        _BROKEN[name] = message
        _warn(message)


def usable() -> dict[str, Robot]:
    """Name -> ``Robot`` of every robot that loads, the default first; each broken one is one warning."""
    out = {}
    for name in names():
        try:
            out[name] = get(name)
        except PluginError:
            continue
    return out


def bus_files(name: str) -> dict[str, tuple]:
    """Role -> the DBC files of each bus of the robot ``name`` (``Bus.dbc_files``): for the rig's own robots
    from ``wheelleg.dbc.ROBOT_BUS_FILES`` without importing them (a reader of a trace needs only its layouts),
    else from the loaded ``Robot``; KeyError (one line) for an unknown or broken robot."""
    if name in dbc.ROBOT_BUS_FILES:
        return dict(dbc.ROBOT_BUS_FILES[name])
    return {bus.role: bus.dbc_files for bus in get(name).buses}


def check_known(name: str) -> None:
    """KeyError (one line) unless the robot ``name`` is installed and loads; the rig's own are known unloaded."""
    if name not in BUILTIN:
        get(name)


def origin(name: str) -> str:
    """'PACKAGE VERSION' the robot ``name`` came from."""
    return entries()[name].origin


def add_argument(parser: argparse.ArgumentParser, help_text: str) -> None:
    """``--robot NAME`` on a command's parser: one of the registered robots."""
    parser.add_argument("--robot", choices=names(), default=None, help=help_text)


def split_name(text: str) -> tuple[str | None, str]:
    """'quadruped/quad-trot' -> ('quadruped', 'quad-trot'); 'balance' -> (None, 'balance')."""
    robot, sep, name = text.rpartition("/")
    return (robot, name) if sep else (None, text)
