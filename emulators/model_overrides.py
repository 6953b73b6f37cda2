"""Plant overrides that change the MuJoCo model itself, applied to the spec before it compiles.

Keys (emulators/overrides.py): body_mass_scale, inertia_scale, com_x_m, com_y_m,
com_z_m (the body's inertial frame), friction (floor, terrain of the floor's friction,
tyres), wheel_radius_scale (the tyre geoms; their inertia follows), hip_damping,
hip_frictionloss (+ _left/_right) and hip_armature (the hip joints), wheel_damping and
wheel_frictionloss (+ _left/_right) (the wheel joints: the M3508's gearbox, whose
armature is its rotor's), imu_tilt_pitch_deg and imu_tilt_roll_deg
(the IMU site's orientation, which its three sensors read in). A key at its
default leaves the spec untouched, so the nominal model compiles bit for bit
as before.
"""
from __future__ import annotations

import math
from typing import Mapping

import mujoco
import numpy as np

from wheelleg.emulators.overrides import OVERRIDES
from wheelleg.emulators.robot import description as D
from wheelleg.emulators.terrain import GROUND_GROUP

_NOMINAL_FRICTION = 1.0  # robot.xml / scene.xml: tyre and floor sliding friction
_WHEELS = tuple(w.name for w in D.WHEEL_DRIVES)  # also their geoms' names
_HIPS = tuple(m.name for m in D.HIP_MOTORS)
_SIDES = ("left", "right")
_HIPS_BY_SIDE = {side: tuple(m.name for m in D.HIP_MOTORS if m.leg == side) for side in _SIDES}
_WHEELS_BY_SIDE = {side: tuple(w.name for w in D.WHEEL_DRIVES if w.leg == side) for side in _SIDES}
# (joints by side, joint attribute, the keys whose sum it is ({side}: that side's key))
_JOINT_LOSSES = (
    (_HIPS_BY_SIDE, "damping", ("hip_damping",)),
    (_HIPS_BY_SIDE, "frictionloss", ("hip_frictionloss", "hip_frictionloss_{side}")),
    (_WHEELS_BY_SIDE, "damping", ("wheel_damping",)),
    (_WHEELS_BY_SIDE, "frictionloss", ("wheel_frictionloss", "wheel_frictionloss_{side}")),
)


def override_model(spec: mujoco.MjSpec, overrides: Mapping[str, float]) -> None:
    """Apply the model-level ``overrides`` (key -> value, checked) to ``spec`` in place."""
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
        _set_friction(spec, value("friction"))
    if changed("wheel_radius_scale"):
        for name in _WHEELS:
            geom = spec.geom(name)
            geom.size = [geom.size[0] * value("wheel_radius_scale"), *geom.size[1:]]
    for joints, attr, total in _JOINT_LOSSES:
        for side, names in joints.items():
            keys = [key.format(side=side) for key in total]
            if any(changed(key) for key in keys):
                for name in names:
                    _set_first(spec.joint(name), attr, sum(value(key) for key in keys))
    if changed("hip_armature"):
        for name in _HIPS:
            spec.joint(name).armature = value("hip_armature")
    if changed("imu_tilt_pitch_deg") or changed("imu_tilt_roll_deg"):
        spec.site("imu").quat = imu_mount_quat(value("imu_tilt_pitch_deg"), value("imu_tilt_roll_deg"))


def _set_first(element, attr: str, number: float) -> None:
    """Set ``element.attr`` to ``number``, or its first entry when it is an array (MuJoCo's
    joint damping is one since 3.3: the linear coefficient first)."""
    current = getattr(element, attr)
    setattr(element, attr, [number, *current[1:]] if np.ndim(current) else number)


def _set_friction(spec: mujoco.MjSpec, sliding: float) -> None:
    """Sliding friction of the tyres and of every ground geom at the floor's nominal value.

    MuJoCo takes the larger coefficient of a contact's two geoms, so both
    sides change; terrain with a friction of its own (an icy patch) keeps it
    where it is the larger one.
    """
    for geom in spec.geoms:
        on_ground = geom.group == GROUND_GROUP and geom.friction[0] == _NOMINAL_FRICTION
        if geom.name in _WHEELS or on_ground:
            geom.friction = [sliding, *geom.friction[1:]]


def imu_mount_quat(pitch_deg: float, roll_deg: float) -> list[float]:
    """Quaternion (w, x, y, z) of the IMU's frame in the body: R = Ry(pitch) Rx(roll),
    pitch > 0 nose down (about +y), roll > 0 right side down (about +x)."""
    p, r = math.radians(pitch_deg) / 2, math.radians(roll_deg) / 2
    cp, sp, cr, sr = math.cos(p), math.sin(p), math.cos(r), math.sin(r)
    return [cp * cr, cp * sr, sp * cr, -sp * sr]
