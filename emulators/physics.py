"""The wheel-legged robot's MuJoCo world: robot.xml in scene.xml, plus terrain.

``Physics`` is a ``World`` (emulators/world.py: the scene compiled with terrain
and overrides, stepping, the body force, IMU and shaft readings, and when each
reading is taken). The plant writes motor torques (``set_motor_torques`` in
``MOTORS`` order each step; ``set_torques`` by name), steps it (``step``) and reads
back what the devices would measure (``motor_states``, ``shaft_state``, ``imu``); the recorder reads ``ground_truth``, which the controller never sees.
Its numbers and conventions are the robot description's
(emulators/robot/description.py), never the controller's; the model is
described in emulators/robot/README.md. ``overrides`` (plant overrides,
emulators/overrides.py) change the model before it is compiled.

Normal forces and ``body_on_ground`` are the contacts of the last step.
Reading never changes the simulation: leg geometry and wheel clearance are
computed on a scratch ``MjData``.
"""
from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np

from wheelleg.emulators.robot import description as D
from wheelleg.emulators.robot import fivebar
from wheelleg.emulators.terrain import GROUND_GROUP, TerrainFeature
from wheelleg.emulators.world import World, euler_zyx

__all__ = ["Physics", "TerrainFeature", "SCENE_PATH", "ROBOT_PATH", "euler_zyx"]

MODEL_DIR = Path(__file__).resolve().parent / "robot"
SCENE_PATH = MODEL_DIR / "scene.xml"
ROBOT_PATH = MODEL_DIR / "robot.xml"

LEGS = ("left", "right")
HIP_NAMES = tuple(m.name for m in D.HIP_MOTORS)
WHEEL_NAMES = tuple(w.name for w in D.WHEEL_DRIVES)
# the rest pose drawn in robot.xml: both thighs on their stops; its shin angles (phi2, phi3)
_REST_PHI = (D.PHI1_STOP_RAD, D.PHI4_STOP_RAD)
_REST_SHINS = fivebar.link_angles(*_REST_PHI)
_RESTING_TILT_RAD = 0.05  # nose down: a resting robot topples forward, every time
_RESTING_HOLD_S = 1.5  # hips held on their stops while the robot topples and lands
_RESTING_SETTLE_S = 1.0  # then limp, to come to rest
_HOLD_KP, _HOLD_KD = 50.0, 0.5  # N m/rad, N m s/rad: the hold, stiff enough, stable at 1 ms
_RAY_START_ABOVE_M = 0.5  # rays for the ground start this far above a wheel's lowest point
_GROUND_ONLY = np.array([i == GROUND_GROUP for i in range(6)], dtype=np.uint8)
_DOWN = np.array([0.0, 0.0, -1.0])
# ground_truth's keys of each leg, made once (it runs every control period)
_LEG_KEYS = {leg: (f"{leg}_leg_length", f"{leg}_leg_angle", f"{leg}_normal_force", f"{leg}_wheel_clearance")
             for leg in LEGS}


def _quat_yaw_pitch(yaw: float, pitch: float) -> np.ndarray:
    """Quaternion (w, x, y, z) of R = Rz(yaw) Ry(pitch), pitch > 0 nose down."""
    cy, sy, cp, sp = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(pitch / 2), math.sin(pitch / 2)
    return np.array([cy * cp, -sy * sp, cy * sp, sy * cp])


def leg_joint_angles(leg: str, phi1: float, phi4: float) -> dict[str, float]:
    """MJCF joint angles (rad) of ``leg`` at hip angles phi1, phi4 (five-bar frame).

    Hips are shaft angles (phi = stop + sign q); the knees' zero is the rest
    pose of robot.xml. Angles in the five-bar frame grow about -y_body, so a
    joint about +y (left) turns by minus their change, about -y (right) by plus.
    Raises ValueError if the loop does not close.
    """
    phi2, phi3 = fivebar.link_angles(phi1, phi4)
    (rest1, rest4), (rest2, rest3) = _REST_PHI, _REST_SHINS
    axis_sign = -1.0 if leg == "left" else 1.0
    joints = {m.name: fivebar.shaft_from_phi(m, phi1 if m.hip == "A" else phi4)
              for m in D.HIP_MOTORS if m.leg == leg}
    joints[f"{leg}_front_knee"] = axis_sign * fivebar.wrap((phi2 - phi1) - (rest2 - rest1))
    joints[f"{leg}_rear_knee"] = axis_sign * fivebar.wrap((phi3 - phi4) - (rest3 - rest4))
    return joints


class Physics(World):
    """The simulated robot and its world. All quantities SI (m, rad, s, N, N m)."""

    SCENE_PATH = SCENE_PATH
    MOTORS = HIP_NAMES + WHEEL_NAMES

    # -- names -> indices ------------------------------------------------------------
    def _index(self) -> None:
        super()._index()
        m = self.model
        self._ray_start = np.zeros(3)  # scratch for mj_ray
        self._body_box = m.geom("body_box").id
        self._wheel_geom = {leg: m.geom(f"{leg}_wheel").id for leg in LEGS}
        self._wheel_size = tuple(float(v) for v in m.geom_size[self._wheel_geom["left"]][:2])  # radius, half width
        self._ground = {i for i in range(m.ngeom) if m.geom_bodyid[i] == 0 and m.geom_group[i] == GROUND_GROUP}
        self._leg_sites = {leg: tuple(m.site(f"{leg}_{point}").id for point in ("hip_a", "hip_e", "front_c"))
                           for leg in LEGS}

    def set_torques(self, hips_nm: dict[str, float], wheels_nm: dict[str, float]) -> None:
        """Motor torques (N m, shaft sign) by joint name, held until changed.

        Names missing from the dicts keep their torque. The model clips each to
        its actuator's ctrlrange (hips +-CG_TORQUE_LIMIT, wheels +-WHEEL_TORQUE_LIMIT).
        """
        self._set_motor_torques(HIP_NAMES, hips_nm)
        self._set_motor_torques(WHEEL_NAMES, wheels_nm)

    # -- ground truth ---------------------------------------------------------------------
    def ground_truth(self) -> dict[str, float]:
        """The simulation's truth for the trace (never for the controller); keys and units:

        t (s); x, y, z body CoM (m, world); roll, pitch, yaw (rad, ZYX, pitch > 0
        nose down); vx, vy, vz (m/s, world); wx, wy, wz (rad/s, body);
        {left,right}_leg_length (m, hip midpoint to wheel axle);
        {left,right}_leg_angle (rad, virtual leg from the world vertical, > 0 with
        the wheel behind the hips); {left,right}_normal_force (N, ground on wheel);
        body_on_ground (1.0 or 0.0); {left,right}_wheel_clearance (m, lowest
        wheel point above the ground below it, < 0 when pressed in).
        """
        out = self.pose_truth()
        yaw = out["yaw"]
        kin = self._kinematics()
        sites = self._kin_site_xpos.tolist()
        cos_yaw, sin_yaw = math.cos(yaw), math.sin(yaw)
        forces, body_down = self._contacts()
        for leg, (length_key, angle_key, force_key, _) in _LEG_KEYS.items():
            (ax, ay, az), (ex, ey, ez), (cx, cy, cz) = (sites[i] for i in self._leg_sites[leg])
            vx, vy, vz = cx - 0.5 * (ax + ex), cy - 0.5 * (ay + ey), cz - 0.5 * (az + ez)
            out[length_key] = math.sqrt(vx * vx + vy * vy + vz * vz)
            out[angle_key] = math.atan2(-(vx * cos_yaw + vy * sin_yaw), -vz)
            out[force_key] = forces[leg]
        out["body_on_ground"] = 1.0 if body_down else 0.0
        for leg, (*_, clearance_key) in _LEG_KEYS.items():
            out[clearance_key] = self._wheel_clearance(kin, leg)
        return out

    def _contacts(self) -> tuple[dict[str, float], bool]:
        """Normal force (N) on each wheel from the ground and objects, and whether
        the body box touches the ground, over the last step."""
        d = self.data
        total = {leg: 0.0 for leg in LEGS}
        body_down = False
        ncon = d.ncon  # read once: each MjData attribute is a binding call
        if ncon == 0:
            return total, body_down
        pairs = d.contact.geom[:ncon].tolist()
        for i, (g1, g2) in enumerate(pairs):
            for leg, g in self._wheel_geom.items():
                if g == g1 or g == g2:
                    mujoco.mj_contactForce(self.model, d, i, self._wrench)
                    total[leg] += float(self._wrench[0])
            if self._body_box in (g1, g2) and (g1 in self._ground or g2 in self._ground):
                body_down = True
        return total, body_down

    def _wheel_clearance(self, kin: mujoco.MjData, leg: str) -> float:
        """Height (m) of a wheel's lowest rim point above the ground straight below it.

        Both rims' lowest points are probed (on a side slope the uphill rim
        touches first); rays see the ground (geom group 0) only.
        """
        g = self._wheel_geom[leg]
        cx, cy, cz = self._kin_geom_xpos[g].tolist()
        rot = self._kin_geom_xmat[g].tolist()
        ux, uy, uz = rot[2], rot[5], rot[8]  # the wheel's axle direction (its z axis)
        # the downward direction in the wheel's plane: -z minus its part along the axle
        dx, dy, dz = uz * ux, uz * uy, uz * uz - 1.0
        norm = math.sqrt(dx * dx + dy * dy + dz * dz)
        if norm > 1e-9:  # else the wheel lies flat and its face is lowest
            dx, dy, dz = dx / norm, dy / norm, dz / norm
        radius, half_width = self._wheel_size
        clearance = math.inf
        start = self._ray_start
        for side in (-half_width, half_width):
            # element by element: a slice assignment from a tuple costs numpy ~0.5 us
            start[0] = cx + side * ux + radius * dx
            start[1] = cy + side * uy + radius * dy
            start[2] = cz + side * uz + radius * dz + _RAY_START_ABOVE_M
            dist = mujoco.mj_ray(self.model, kin, start, _DOWN, _GROUND_ONLY, 1, -1, None)
            if dist >= 0:
                clearance = min(clearance, dist - _RAY_START_ABOVE_M)
        return clearance

    # -- resets ---------------------------------------------------------------------------
    def _set_legs(self, lengths_m: dict[str, float]) -> None:
        for leg, length in lengths_m.items():
            phi1, phi4 = fivebar.hip_angles(length, math.pi / 2)
            for joint, angle in leg_joint_angles(leg, phi1, phi4).items():
                j = self._joint_id[joint]
                lo, hi = self.model.jnt_range[j]
                if self.model.jnt_limited[j] and not lo - 1e-9 <= angle <= hi + 1e-9:
                    raise ValueError(f"leg length {length:.4f} m needs {joint} at {angle:.4f} rad, "
                                     f"outside its range [{lo:.4f}, {hi:.4f}]")
                self.data.qpos[self._qpos_adr(joint)] = angle

    def _clearances(self) -> dict[str, float]:
        kin = self._kinematics()
        return {leg: self._wheel_clearance(kin, leg) for leg in LEGS}

    def reset_standing(self, leg_length_m: float = 0.17, x_m: float = 0.0, y_m: float = 0.0,
                       yaw_rad: float = 0.0, drop_height_m: float = 0.0, pitch_rad: float = 0.0,
                       fit_legs_to_ground: bool = False) -> None:
        """Stand the robot: both virtual legs leg_length_m long and straight down in
        the body frame (phi0 = pi/2), the loops closed exactly, the body CoM at
        (x_m, y_m) with that yaw and pitch (rad, pitch > 0 nose down), no roll, the
        lower wheel drop_height_m (m) above the ground below it, all at rest,
        torques and forces zero, time 0.

        With ``fit_legs_to_ground`` (uneven ground: a side slope, a bump) the leg
        over the lower ground is lengthened until both wheels touch.
        Raises ValueError for a leg length the hips cannot reach.
        """
        for name, v in (("leg_length_m", leg_length_m), ("x_m", x_m), ("y_m", y_m), ("yaw_rad", yaw_rad),
                        ("drop_height_m", drop_height_m), ("pitch_rad", pitch_rad)):
            if not math.isfinite(v):
                raise ValueError(f"{name} must be finite, got {v}")
        if drop_height_m < 0 or abs(pitch_rad) >= math.pi / 2:
            raise ValueError(f"need drop_height_m >= 0 and |pitch_rad| < pi/2, got {drop_height_m}, {pitch_rad}")
        self._reset_data()
        d = self.data
        lengths = {leg: leg_length_m for leg in LEGS}
        self._set_legs(lengths)
        d.qpos[0:3] = [x_m, y_m, 1.0 + leg_length_m]
        d.qpos[3:7] = _quat_yaw_pitch(yaw_rad, pitch_rad)
        clear = self._clearances()
        if fit_legs_to_ground:
            low_leg = max(clear, key=clear.get)
            lengths[low_leg] += (clear[low_leg] - min(clear.values())) / math.cos(pitch_rad)
            self._set_legs(lengths)
            clear = self._clearances()
        if not all(math.isfinite(c) for c in clear.values()):
            raise ValueError(f"no ground below the wheels at x={x_m}, y={y_m}")
        d.qpos[2] -= min(clear.values()) - drop_height_m
        d.time = 0.0
        mujoco.mj_forward(self.model, d)

    def reset_resting(self) -> None:
        """The robot as it lies with no torque: every hip on its mechanical stop
        (shaft angle 0), at the origin facing +x, settled at rest, time 0.

        As a person would put it down: on its wheels tilted slightly nose down
        (so it topples forward onto the front of its body; with the body's CoM
        6-7 mm or more behind the nominal it goes back onto its tail) with the hips
        held on their stops by a position hold while it falls (the impact would
        otherwise fling the limp legs off their stops), then released to settle
        with zero torque. Its weight keeps the thighs on their stops. All of it
        runs inside this call and is deterministic.
        """
        self._reset_data()
        d = self.data
        d.qpos[0:3] = [0.0, 0.0, 1.0]
        d.qpos[3:7] = _quat_yaw_pitch(0.0, _RESTING_TILT_RAD)
        d.qpos[2] -= min(self._clearances().values())
        mujoco.mj_forward(self.model, d)
        dt = self.model.opt.timestep
        for _ in range(round(_RESTING_HOLD_S / dt)):
            self.set_torques({name: -_HOLD_KP * q - _HOLD_KD * w
                              for name, (q, w) in ((n, self.shaft_state(n)) for n in HIP_NAMES)}, {})
            mujoco.mj_step(self.model, d)
        d.ctrl[:] = 0.0
        self.step(round(_RESTING_SETTLE_S / dt))
        d.time = 0.0
        mujoco.mj_forward(self.model, d)
