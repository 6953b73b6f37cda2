"""Plant overrides that change the MuJoCo model itself, applied to the spec before it compiles.

Keys (emulators/overrides.py): body_mass_scale, inertia_scale, com_x_m, com_y_m,
com_z_m (the body's inertial frame), friction (floor, terrain of the floor's friction,
tyres or feet), wheel_radius_scale (the tyre geoms; their inertia follows), hip_damping,
hip_frictionloss (+ _left/_right), added to what the model describes, and hip_armature
(the CyberGear joints), joint_armature_scale (the quadruped's), wheel_damping and
wheel_frictionloss (+ _left/_right) (the wheel joints: the M3508's gearbox, whose
armature is its rotor's), imu_tilt_pitch_deg and imu_tilt_roll_deg
(the IMU site's orientation, which its three sensors read in). Which joints and
geoms those are is the robot's ``Targets`` (the wheel-legged robot's by default;
the quadruped's CyberGear joints are all twelve). A key at its default leaves the
spec untouched, so the nominal model compiles bit for bit as before.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import mujoco
import numpy as np

from wheelleg.emulators.overrides import OVERRIDES
from wheelleg.emulators.robot import description as D
from wheelleg.emulators.terrain import GROUND_GROUP

_NOMINAL_FRICTION = 1.0  # robot.xml / scene.xml: tyre (foot) and floor sliding friction
_SIDES = ("left", "right")


@dataclass(frozen=True)
class Targets:
    """What of a robot's model the joint and contact keys act on: joint names by side
    ("left", "right") of its CyberGear joints (the ``hip_*`` keys) and of its wheel drives
    (the ``wheel_*`` keys; empty when it has none), and the geoms that touch the floor
    (the tyres or feet, ``friction`` and, on wheels, ``wheel_radius_scale``)."""

    cybergears: dict
    wheels: dict
    contact_geoms: tuple[str, ...]


WHEEL_LEGGED = Targets(
    cybergears={side: tuple(m.name for m in D.HIP_MOTORS if m.leg == side) for side in _SIDES},
    wheels={side: tuple(w.name for w in D.WHEEL_DRIVES if w.leg == side) for side in _SIDES},
    contact_geoms=tuple(w.name for w in D.WHEEL_DRIVES))  # the wheels' joints, bodies and tyre geoms share names
# (targets' group, joint attribute, the keys whose sum is added to it ({side}: that side's key))
_JOINT_LOSSES = (
    ("cybergears", "damping", ("hip_damping",)),
    ("cybergears", "frictionloss", ("hip_frictionloss", "hip_frictionloss_{side}")),
    ("wheels", "damping", ("wheel_damping",)),
    ("wheels", "frictionloss", ("wheel_frictionloss", "wheel_frictionloss_{side}")),
)


def override_model(spec: mujoco.MjSpec, overrides: Mapping[str, float], targets: Targets = WHEEL_LEGGED) -> None:
    """Apply the model-level ``overrides`` (key -> value, checked) to ``spec`` in place, on the
    joints and geoms ``targets`` names."""
    def changed(key: str) -> bool:
        return key in overrides and overrides[key] != OVERRIDES[key].default

    def value(key: str) -> float:
        return float(overrides.get(key, OVERRIDES[key].default))

    body = spec.body("body")
    if changed("body_mass_scale") or changed("inertia_scale"):
        body.mass = body.mass * value("body_mass_scale")
        body.inertia = np.asarray(body.inertia) * value("body_mass_scale") * value("inertia_scale")
    if changed("com_x_m") or changed("com_y_m") or changed("com_z_m"):
        body.ipos = np.asarray(body.ipos) + [value("com_x_m"), value("com_y_m"), value("com_z_m")]
    if changed("friction"):
        _set_friction(spec, value("friction"), targets.contact_geoms)
    if changed("wheel_radius_scale"):
        for name in (n for side in _SIDES for n in targets.wheels.get(side, ())):
            geom = spec.geom(name)
            geom.size = [geom.size[0] * value("wheel_radius_scale"), *geom.size[1:]]
    for group, attr, total in _JOINT_LOSSES:
        for side, names in getattr(targets, group).items():
            keys = [key.format(side=side) for key in total]
            if any(changed(key) for key in keys):
                for name in names:
                    joint = spec.joint(name)
                    _set_first(joint, attr, _first(getattr(joint, attr)) + sum(value(key) for key in keys))
    cybergears = [name for side in _SIDES for name in targets.cybergears.get(side, ())]
    if changed("hip_armature"):
        for name in cybergears:
            spec.joint(name).armature = value("hip_armature")
    if changed("joint_armature_scale"):
        for name in cybergears:
            spec.joint(name).armature = spec.joint(name).armature * value("joint_armature_scale")
    if changed("imu_tilt_pitch_deg") or changed("imu_tilt_roll_deg"):
        spec.site("imu").quat = imu_mount_quat(value("imu_tilt_pitch_deg"), value("imu_tilt_roll_deg"))


def _first(current) -> float:
    """A joint attribute's number: itself, or its first entry when it is an array."""
    return float(current[0]) if np.ndim(current) else float(current)


def _set_first(element, attr: str, number: float) -> None:
    """Set ``element.attr`` to ``number``, or its first entry when it is an array (MuJoCo's
    joint damping is one since 3.3: the linear coefficient first)."""
    current = getattr(element, attr)
    setattr(element, attr, [number, *current[1:]] if np.ndim(current) else number)


def _set_friction(spec: mujoco.MjSpec, sliding: float, contact_geoms: tuple[str, ...]) -> None:
    """Sliding friction of the ``contact_geoms`` (tyres, feet) and of every ground geom at the
    floor's nominal value.

    MuJoCo takes the larger coefficient of a contact's two geoms, so both
    sides change; terrain with a friction of its own (an icy patch) keeps it
    where it is the larger one.
    """
    for geom in spec.geoms:
        on_ground = geom.group == GROUND_GROUP and geom.friction[0] == _NOMINAL_FRICTION
        if geom.name in contact_geoms or on_ground:
            geom.friction = [sliding, *geom.friction[1:]]


def imu_mount_quat(pitch_deg: float, roll_deg: float) -> list[float]:
    """Quaternion (w, x, y, z) of the IMU's frame in the body: R = Ry(pitch) Rx(roll),
    pitch > 0 nose down (about +y), roll > 0 right side down (about +x)."""
    p, r = math.radians(pitch_deg) / 2, math.radians(roll_deg) / 2
    cp, sp, cr, sr = math.cos(p), math.sin(p), math.cos(r), math.sin(r)
    return [cp * cr, cp * sr, sp * cr, -sp * sr]
