"""The quadruped's MuJoCo world: robot.xml in scene.xml, plus terrain.

``QuadrupedPhysics`` is a ``World`` (emulators/world.py: stepping, the body
force, IMU and shaft readings, and when each is taken). The plant writes the
twelve joint torques (``set_motor_torques``, in ``MOTORS`` order; ``set_torques``
by name), steps it and reads back what the CyberGears and the IMU measure; the recorder reads ``ground_truth``. Its
numbers and conventions are the quadruped's description
(emulators/quadruped/description.py), never its controller's.

Poses (each at rest, time 0, torques and forces zero): ``reset_standing``
(feet under the hips at a height), ``reset_lying`` (folded on its belly, or on
its side) as a person would put it down and let it settle with the motors off.
"""
from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np

from wheelleg.emulators.model_overrides import Targets
from wheelleg.emulators.quadruped import description as D
from wheelleg.emulators.terrain import GROUND_GROUP
from wheelleg.emulators.world import World

MODEL_DIR = Path(__file__).resolve().parent
SCENE_PATH = MODEL_DIR / "scene.xml"
JOINT_NAMES = tuple(m.name for m in D.JOINT_MOTORS)
FOLDED_RAD = {"abduction": 0.0, "thigh": 0.9, "calf": D.CALF_RANGE_RAD[0]}  # on its belly: knee fully bent
SIDE_HEIGHT_M = 0.25  # on its side: the legs as they stood (stance_angles) when it toppled
_HOLD_KP, _HOLD_KD = 30.0, 0.5  # N m/rad, N m s/rad: the joints held while it is put down
_HOLD_S = 0.5  # s held in the folded pose while it lands
_SETTLE_S = 1.0  # s then with the motors off, to come to rest


def stance_angles(height_m: float) -> dict[str, float]:
    """Thigh and calf angles (rad) that put the foot's centre ``height_m`` straight below the thigh axis
    (abduction 0), knee behind the hip; ValueError for a height the leg cannot reach."""
    l2, l3 = D.THIGH_M, D.CALF_M
    if not abs(l2 - l3) < height_m < l2 + l3:
        raise ValueError(f"height {height_m} m: a leg reaches {abs(l2 - l3):.3f}..{l2 + l3:.3f} m")
    thigh = math.acos((l2 * l2 + height_m * height_m - l3 * l3) / (2 * l2 * height_m))
    calf = -math.acos((height_m * height_m - l2 * l2 - l3 * l3) / (2 * l2 * l3))
    return {"abduction": 0.0, "thigh": thigh, "calf": calf}


class QuadrupedPhysics(World):
    """The simulated quadruped and its world. All quantities SI (m, rad, s, N, N m)."""

    SCENE_PATH = SCENE_PATH
    MOTORS = JOINT_NAMES
    # the hip_* keys act on all twelve CyberGear joints (left: FL, RL), friction on the feet
    OVERRIDE_TARGETS = Targets(
        cybergears={side: tuple(m.name for m in D.JOINT_MOTORS if (D.side_sign(m.leg) > 0) == (side == "left"))
                    for side in ("left", "right")},
        wheels={}, contact_geoms=tuple(f"{leg}_foot" for leg in D.LEGS))

    def _index(self) -> None:
        super()._index()
        m = self.model
        self._body_box = m.geom("body_box").id
        self._foot_geom = {leg: m.geom(f"{leg}_foot").id for leg in D.LEGS}
        self._foot_site = {leg: m.site(f"{leg}_foot").id for leg in D.LEGS}
        self._ground = {i for i in range(m.ngeom) if m.geom_bodyid[i] == 0 and m.geom_group[i] == GROUND_GROUP}

    def set_torques(self, torques_nm: dict[str, float]) -> None:
        """Joint motor torques (N m, about each joint's axis) by joint name, held until changed;
        clipped to the actuators' +-12 N m."""
        self._set_motor_torques(JOINT_NAMES, torques_nm)

    # -- ground truth ---------------------------------------------------------------------
    def ground_truth(self) -> dict[str, float]:
        """The simulation's truth for the trace (never for the controller); keys and units:

        the body's pose and velocity (``World.pose_truth``: t, x, y, z, roll, pitch,
        yaw, vx, vy, vz, wx, wy, wz); height (m, the body centre above the mean of
        the four foot centres, along world z: the hip plane above the feet);
        {FR,FL,RR,RL}_foot_force (N, normal force of the ground on the foot, last
        step); {FR,FL,RR,RL}_foot_z (m, world, the foot's centre); body_on_ground
        (1.0 when the body box or a thigh or calf touches the ground, else 0.0).
        """
        out = self.pose_truth()
        sites = self._kinematics().site_xpos
        feet_z = {leg: float(sites[self._foot_site[leg], 2]) for leg in D.LEGS}
        out["height"] = out["z"] - sum(feet_z.values()) / 4
        forces, body_down = self._contacts()
        for leg in D.LEGS:
            out[f"{leg}_foot_force"] = forces[leg]
            out[f"{leg}_foot_z"] = feet_z[leg]
        out["body_on_ground"] = 1.0 if body_down else 0.0
        return out

    def _contacts(self) -> tuple[dict[str, float], bool]:
        """Normal force (N) on each foot over the last step, and whether anything of the robot but a
        foot touches the ground."""
        d = self.data
        total = {leg: 0.0 for leg in D.LEGS}
        down = False
        feet = {g: leg for leg, g in self._foot_geom.items()}
        for i in range(d.ncon):
            g1, g2 = int(d.contact.geom[i][0]), int(d.contact.geom[i][1])
            leg = feet.get(g1, feet.get(g2))
            if leg is not None:
                mujoco.mj_contactForce(self.model, d, i, self._wrench)
                total[leg] += float(self._wrench[0])
            elif g1 in self._ground or g2 in self._ground:
                down = True
        return total, down

    # -- poses ------------------------------------------------------------------------------
    def _set_joints(self, angles: dict[str, float]) -> None:
        """Every leg's joints at ``angles`` (joint kind -> rad)."""
        for motor in D.JOINT_MOTORS:
            self.data.qpos[self._qpos_adr(motor.name)] = angles[motor.joint]

    def _lowest_point_m(self) -> float:
        """The lowest point (m, world z) of the robot's collision geoms now: feet and links as spheres
        and capsules ends, the body box by its corners."""
        kin = self._kinematics()
        m = self.model
        low = math.inf
        for g in range(m.ngeom):
            if m.geom_bodyid[g] == 0 or m.geom_contype[g] == 0:
                continue
            centre, rot, size = kin.geom_xpos[g], kin.geom_xmat[g].reshape(3, 3), m.geom_size[g]
            if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
                reach = float(np.abs(rot[2]) @ size)
            elif m.geom_type[g] == mujoco.mjtGeom.mjGEOM_CAPSULE:
                reach = size[0] + size[1] * abs(rot[2, 2])
            else:
                reach = size[0]
            low = min(low, float(centre[2]) - reach)
        return low

    def reset_standing(self, height_m: float = 0.25, x_m: float = 0.0, y_m: float = 0.0,
                       yaw_rad: float = 0.0) -> None:
        """Stand it: every foot's centre ``height_m`` straight below its thigh axis, the body level
        at (x_m, y_m) with that yaw, the feet on the floor, all at rest, time 0."""
        self._reset_data()
        self._set_joints(stance_angles(height_m))
        self.data.qpos[0:3] = [x_m, y_m, 1.0]
        self.data.qpos[3:7] = [math.cos(yaw_rad / 2), 0.0, 0.0, math.sin(yaw_rad / 2)]
        self.data.qpos[2] -= self._lowest_point_m()
        self.data.time = 0.0
        mujoco.mj_forward(self.model, self.data)

    def reset_lying(self, on_side: bool = False) -> None:
        """Lying with the motors off: on its belly with the legs folded (``FOLDED_RAD``), or
        (``on_side``) toppled onto its left side with the legs as they stood (``SIDE_HEIGHT_M``;
        it comes to rest leaning on its left legs, rolled about 50 deg). The pose is held while
        it lands, then the motors are off until it rests; time 0."""
        self._reset_data()
        pose = stance_angles(SIDE_HEIGHT_M) if on_side else FOLDED_RAD
        self._set_joints(pose)
        roll = -math.pi / 2 if on_side else 0.0
        self.data.qpos[0:3] = [0.0, 0.0, 1.0]
        self.data.qpos[3:7] = [math.cos(roll / 2), math.sin(roll / 2), 0.0, 0.0]
        self.data.qpos[2] -= self._lowest_point_m() - 0.01
        mujoco.mj_forward(self.model, self.data)
        dt = self.model.opt.timestep
        for _ in range(round(_HOLD_S / dt)):
            self.set_torques({m.name: -_HOLD_KP * (q - pose[m.joint]) - _HOLD_KD * w
                              for m, (q, w) in ((m, self.shaft_state(m.name)) for m in D.JOINT_MOTORS)})
            mujoco.mj_step(self.model, self.data)
        self.data.ctrl[:] = 0.0
        self.step(round(_SETTLE_S / dt))
        self.data.time = 0.0
        mujoco.mj_forward(self.model, self.data)
