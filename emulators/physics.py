"""The MuJoCo world the rig's plant drives: robot.xml in scene.xml, plus terrain.

``Physics`` owns one ``MjModel``/``MjData``. The plant writes motor torques
(``set_torques``), steps it (``step``) and reads back what the devices would
measure (``shaft_state``, ``imu``); the recorder reads ``ground_truth``, which
the controller never sees. Its numbers and conventions are the robot
description's (emulators/robot/description.py), never the controller's; the
model is described in emulators/robot/README.md. ``overrides`` (plant
overrides, emulators/overrides.py) change the model before it is compiled.

Timing of the readings. ``mj_step`` evaluates sensors and contacts at the
state it starts from, then integrates. So after ``step``:
  - shaft angles and speeds, body pose and velocity (``shaft_state``, the pose
    fields of ``ground_truth``) are the new state at ``time_s``;
  - ``imu`` is the IMU sensors at the start of the last step (one timestep
    old), its specific force the one that acted over that step;
  - normal forces and ``body_on_ground`` are the contacts of the last step.
Reading never changes the simulation: leg geometry and wheel clearance are
computed on a scratch ``MjData``.

Determinism: MuJoCo steps single-threaded, so the same calls give
bit-identical states.
"""
from __future__ import annotations

import math
import operator
from pathlib import Path
from typing import Mapping, Sequence

import mujoco
import numpy as np

from wheelleg.emulators.model_overrides import override_model
from wheelleg.emulators.robot import description as D
from wheelleg.emulators.robot import fivebar
from wheelleg.emulators.terrain import GROUND_GROUP, TerrainFeature, add_to_spec

__all__ = ["Physics", "TerrainFeature", "SCENE_PATH", "ROBOT_PATH"]

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


def _quat_yaw_pitch(yaw: float, pitch: float) -> np.ndarray:
    """Quaternion (w, x, y, z) of R = Rz(yaw) Ry(pitch), pitch > 0 nose down."""
    cy, sy, cp, sp = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(pitch / 2), math.sin(pitch / 2)
    return np.array([cy * cp, -sy * sp, cy * sp, sy * cp])


def euler_zyx(quat: np.ndarray) -> tuple[float, float, float]:
    """(roll, pitch, yaw) in rad, ZYX, of the body->world quaternion (w, x, y, z) (4,)."""
    w, x, y, z = quat
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


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


class Physics:
    """The simulated robot and its world. All quantities SI (m, rad, s, N, N m)."""

    def __init__(self, terrain: Sequence[TerrainFeature] = (), timestep_s: float = 0.001,
                 overrides: Mapping[str, float] | None = None):
        if not (math.isfinite(timestep_s) and 0 < timestep_s <= 0.01):
            raise ValueError(f"timestep_s must be in (0, 0.01] s, got {timestep_s}")
        self.terrain = tuple(terrain)
        spec = mujoco.MjSpec.from_file(str(SCENE_PATH))
        spec.option.timestep = timestep_s
        self.terrain_names = add_to_spec(spec, self.terrain)
        override_model(spec, overrides or {})
        self.spec = spec  # what was compiled (a rig trace attaches its XML when the plant is overridden)
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        self._scratch = mujoco.MjData(self.model)  # for readings that must not touch self.data
        # numpy views into MjData's C memory, cached: the attribute lookups cost
        # microseconds each and ground_truth runs every control period
        self._qpos, self._qvel = self.data.qpos, self.data.qvel
        self._kin_qpos, self._kin_site_xpos = self._scratch.qpos, self._scratch.site_xpos
        self._kin_geom_xpos, self._kin_geom_xmat = self._scratch.geom_xpos, self._scratch.geom_xmat
        self._index()
        self._force_world = np.zeros(3)
        self._force_point_body = np.zeros(3)
        self._wrench = np.zeros(6)  # scratch for mj_contactForce
        self._ray_start = np.zeros(3)  # scratch for mj_ray
        self._reset_data()
        mujoco.mj_forward(self.model, self.data)

    # -- names -> indices ------------------------------------------------------------
    def _index(self) -> None:
        m = self.model
        self._joint_id = {m.joint(i).name: i for i in range(m.njnt)}
        self._shafts = {}
        for name in HIP_NAMES + WHEEL_NAMES:
            j = m.joint(name).id
            self._shafts[name] = (int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j]))
        self._actuator = {name: m.actuator(name).id for name in HIP_NAMES + WHEEL_NAMES}
        self._body = m.body("body").id
        self._com_body = m.body_ipos[self._body].copy()  # m, body frame: the nominal CoM is its origin
        self._body_box = m.geom("body_box").id
        self._wheel_geom = {leg: m.geom(f"{leg}_wheel").id for leg in LEGS}
        self._wheel_size = tuple(float(v) for v in m.geom_size[self._wheel_geom["left"]][:2])  # radius, half width
        self._ground = {i for i in range(m.ngeom) if m.geom_bodyid[i] == 0 and m.geom_group[i] == GROUND_GROUP}
        self._leg_sites = {leg: tuple(m.site(f"{leg}_{point}").id for point in ("hip_a", "hip_e", "front_c"))
                           for leg in LEGS}
        sensors = [m.sensor(name) for name in ("imu_quat", "imu_gyro", "imu_accel")]
        self._quat_s, self._gyro_s, self._accel_s = (slice(int(s.adr[0]), int(s.adr[0] + s.dim[0])) for s in sensors)
        self._projectiles = [(name, f) for name, f in zip(self.terrain_names, self.terrain) if f.kind == "projectile"]

    def _qpos_adr(self, joint: str) -> int:
        return int(self.model.jnt_qposadr[self._joint_id[joint]])

    # -- time, torques, stepping ------------------------------------------------------
    @property
    def time_s(self) -> float:
        """Simulated time (s) since the last reset."""
        return float(self.data.time)

    def set_torques(self, hips_nm: dict[str, float], wheels_nm: dict[str, float]) -> None:
        """Motor torques (N m, shaft sign) by joint name, held until changed.

        Names missing from the dicts keep their torque. The model clips each to
        its actuator's ctrlrange (hips +-CG_TORQUE_LIMIT, wheels +-WHEEL_TORQUE_LIMIT).
        """
        for names, torques in ((HIP_NAMES, hips_nm), (WHEEL_NAMES, wheels_nm)):
            for name, value in torques.items():
                if name not in names:
                    raise KeyError(f"no motor named {name!r} here; expected one of {names}")
                value = float(value)
                if not math.isfinite(value):
                    raise ValueError(f"torque for {name} must be finite, got {value}")
                self.data.ctrl[self._actuator[name]] = value

    def apply_body_force(self, force_world_n, point_body_m=(0.0, 0.0, 0.0)) -> None:
        """Hold a force (N, world frame, (3,)) on the body at ``point_body_m`` (m, body frame, (3,)).

        It acts until changed; a zero force releases it. Its moment about the
        CoM follows the body as it turns.
        """
        force, point = np.asarray(force_world_n, dtype=float), np.asarray(point_body_m, dtype=float)
        if force.shape != (3,) or point.shape != (3,) or not (np.all(np.isfinite(force)) and np.all(np.isfinite(point))):
            raise ValueError(f"force and point must be finite 3-vectors, got {force_world_n}, {point_body_m}")
        self._force_world, self._force_point_body = force.copy(), point.copy()
        if not force.any():
            self.data.xfrc_applied[self._body] = 0.0

    def _update_body_force(self) -> None:
        rot = np.empty(9)
        mujoco.mju_quat2Mat(rot, self.data.qpos[3:7])
        # the force acts at the CoM (MuJoCo's xipos): the arm is from there (0 unless a com override moved it)
        arm = rot.reshape(3, 3) @ (self._force_point_body - self._com_body)
        self.data.xfrc_applied[self._body, :3] = self._force_world
        self.data.xfrc_applied[self._body, 3:] = np.cross(arm, self._force_world)

    def step(self, n: int = 1) -> None:
        """Advance ``n`` timesteps with the torques and force that are set."""
        n = operator.index(n)  # an integer, numpy's too
        if n < 0:
            raise ValueError(f"n must be >= 0, got {n}")
        m, d = self.model, self.data
        held = bool(self._force_world.any())
        for _ in range(n):
            if held:
                self._update_body_force()
            mujoco.mj_step(m, d)

    # -- device readings ----------------------------------------------------------------
    def shaft_state(self, name: str) -> tuple[float, float]:
        """(angle in rad, speed in rad/s) of a hip or wheel motor's shaft, as its encoder reads.

        Hips: the shaft angle, 0 with the thigh on its stop. Wheels: the output
        shaft relative to its link BC (unbounded, it counts turns).
        """
        try:
            qadr, dadr = self._shafts[name]
        except KeyError:
            raise KeyError(f"no motor named {name!r}; expected one of {HIP_NAMES + WHEEL_NAMES}") from None
        return float(self._qpos[qadr]), float(self._qvel[dadr])

    def imu(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """IMU at the body CoM: quaternion w,x,y,z body->world (4,), gyro rad/s body (3,),
        specific force m/s^2 body (3,) (+9.81 on z at rest). One timestep old (module doc)."""
        s = self.data.sensordata
        return s[self._quat_s].copy(), s[self._gyro_s].copy(), s[self._accel_s].copy()

    def warnings(self) -> dict[str, int]:
        """MuJoCo's warning counters that are non-zero, by mjtWarning name."""
        return {mujoco.mjtWarning(i).name: int(w.number) for i, w in enumerate(self.data.warning) if w.number}

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
        d = self.data
        qpos, qvel = self._qpos[:7].tolist(), self._qvel[:6].tolist()
        roll, pitch, yaw = euler_zyx(qpos[3:7])
        out = {"t": float(d.time), "x": qpos[0], "y": qpos[1], "z": qpos[2],
               "roll": roll, "pitch": pitch, "yaw": yaw,
               "vx": qvel[0], "vy": qvel[1], "vz": qvel[2], "wx": qvel[3], "wy": qvel[4], "wz": qvel[5]}
        kin = self._kinematics()
        sites = self._kin_site_xpos.tolist()
        cos_yaw, sin_yaw = math.cos(yaw), math.sin(yaw)
        forces, body_down = self._contacts()
        for leg in LEGS:
            (ax, ay, az), (ex, ey, ez), (cx, cy, cz) = (sites[i] for i in self._leg_sites[leg])
            vx, vy, vz = cx - 0.5 * (ax + ex), cy - 0.5 * (ay + ey), cz - 0.5 * (az + ez)
            out[f"{leg}_leg_length"] = math.sqrt(vx * vx + vy * vy + vz * vz)
            out[f"{leg}_leg_angle"] = math.atan2(-(vx * cos_yaw + vy * sin_yaw), -vz)
            out[f"{leg}_normal_force"] = forces[leg]
        out["body_on_ground"] = 1.0 if body_down else 0.0
        for leg in LEGS:
            out[f"{leg}_wheel_clearance"] = self._wheel_clearance(kin, leg)
        return out

    def _kinematics(self) -> mujoco.MjData:
        """The scratch data with positions of the current state."""
        self._kin_qpos[:] = self._qpos
        mujoco.mj_kinematics(self.model, self._scratch)
        return self._scratch

    def _contacts(self) -> tuple[dict[str, float], bool]:
        """Normal force (N) on each wheel from the ground and objects, and whether
        the body box touches the ground, over the last step."""
        d = self.data
        total = {leg: 0.0 for leg in LEGS}
        body_down = False
        if d.ncon == 0:
            return total, body_down
        pairs = d.contact.geom[:d.ncon].tolist()
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
        for side in (-half_width, half_width):
            self._ray_start[:] = (cx + side * ux + radius * dx, cy + side * uy + radius * dy,
                                  cz + side * uz + radius * dz + _RAY_START_ABOVE_M)
            dist = mujoco.mj_ray(self.model, kin, self._ray_start, _DOWN, _GROUND_ONLY, 1, -1, None)
            if dist >= 0:
                clearance = min(clearance, dist - _RAY_START_ABOVE_M)
        return clearance

    # -- resets ---------------------------------------------------------------------------
    def _reset_data(self) -> None:
        mujoco.mj_resetData(self.model, self.data)
        self._force_world[:] = 0.0
        for name, f in self._projectiles:
            self._place_projectile(name, f.position_m, f.velocity_mps)

    def _place_projectile(self, name: str, position_m, velocity_mps) -> None:
        j = self._joint_id[name]
        qadr, dadr = int(self.model.jnt_qposadr[j]), int(self.model.jnt_dofadr[j])
        self.data.qpos[qadr:qadr + 7] = [*position_m, 1.0, 0.0, 0.0, 0.0]
        self.data.qvel[dadr:dadr + 6] = [*velocity_mps, 0.0, 0.0, 0.0]

    def launch_projectile(self, index: int, position_m, velocity_mps) -> None:
        """Put projectile number ``index`` (in terrain order, projectiles only) at
        ``position_m`` (m, world, (3,)) moving at ``velocity_mps`` (m/s, world, (3,))."""
        pos, vel = np.asarray(position_m, dtype=float), np.asarray(velocity_mps, dtype=float)
        if pos.shape != (3,) or vel.shape != (3,) or not (np.all(np.isfinite(pos)) and np.all(np.isfinite(vel))):
            raise ValueError(f"position and velocity must be finite 3-vectors, got {position_m}, {velocity_mps}")
        if not 0 <= index < len(self._projectiles):
            raise IndexError(f"projectile {index} does not exist ({len(self._projectiles)} in the scene)")
        self._place_projectile(self._projectiles[index][0], pos, vel)

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
        (so it always topples forward onto the front of its body) with the hips
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
