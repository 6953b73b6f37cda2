"""The robots the rig serves, as plug-ins: a table of registered descriptions.

Like python-can's interface table (``can.interfaces.BACKENDS``: a name ->
the module and class that implement it, imported on first use), ``ROBOTS``
maps a robot's name to the module and attribute that hold its ``Robot``;
``get(name)`` imports it. The wheel-legged robot is ``DEFAULT``: every command
that takes ``--robot`` (or a ``ROBOT/SCENARIO`` name) means it when none is given.

A ``Robot`` says everything the rig needs to run one: its buses with their
devices and CAN ids, its MuJoCo model, its scenarios, its controller program
and control period, and the three factories the rig calls (physics, plant,
in-process controller node). The rig itself (hil/run/rig.py) names no robot.
"""
from __future__ import annotations

import argparse
import importlib
import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import cantools

from wheelleg.dbc import load_bus

DEFAULT = "wheel-legged"
ROBOTS: dict[str, tuple[str, str]] = {
    "wheel-legged": ("wheelleg.hil.robots.wheel_legged", "ROBOT"),
    "quadruped": ("wheelleg.hil.robots.quadruped", "ROBOT"),
}


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
        """Role -> the cantools database of that bus (``wheelleg.dbc.load_bus``: its files per robot)."""
        return {role: load_bus(role, robot=self.name) for role in self.roles}

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


def names() -> tuple[str, ...]:
    """Every registered robot, the default first."""
    return (DEFAULT, *sorted(n for n in ROBOTS if n != DEFAULT))


def get(name: str | None = None) -> Robot:
    """The registered robot ``name`` (None: the default); KeyError (one line) for an unknown one."""
    name = DEFAULT if name is None else name
    if name not in ROBOTS:
        raise KeyError(f"no robot {name!r}; known: {', '.join(names())}")
    module, attribute = ROBOTS[name]
    return getattr(importlib.import_module(module), attribute)


def add_argument(parser: argparse.ArgumentParser, help_text: str) -> None:
    """``--robot NAME`` on a command's parser: one of the registered robots."""
    parser.add_argument("--robot", choices=names(), default=None, help=help_text)


def split_name(text: str) -> tuple[str | None, str]:
    """'quadruped/quad-trot' -> ('quadruped', 'quad-trot'); 'balance' -> (None, 'balance')."""
    robot, sep, name = text.rpartition("/")
    return (robot, name) if sep else (None, text)
