"""What every robot's MuJoCo world shares: a scene compiled with terrain and overrides, stepped and read.

``World`` owns one ``MjModel``/``MjData`` built from a robot's scene.xml (the
scene ``<include>``s the robot), terrain (emulators/terrain.py) and the
model-level plant overrides (emulators/model_overrides.py). A robot's physics
subclasses it (``Physics``: the wheel-legged robot; ``QuadrupedPhysics``) and
adds its own readings and poses. The robot's model must have a free body
``body`` with an ``imu`` site and the sensors ``imu_quat``, ``imu_gyro``,
``imu_accel``, and a ``motor`` actuator named like each joint in ``MOTORS``.

Timing of the readings. ``mj_step`` evaluates sensors and contacts at the
state it starts from, then integrates. So after ``step``:
  - shaft angles and speeds, body pose and velocity (``shaft_state``,
    ``pose_truth``) are the new state at ``time_s``;
  - ``imu`` is the IMU sensors at the start of the last step (one timestep
    old), its specific force the one that acted over that step;
  - contacts are those of the last step.

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

from wheelleg.emulators.model_overrides import WHEEL_LEGGED, Targets, override_model
from wheelleg.emulators.terrain import TerrainFeature, add_to_spec


def euler_zyx(quat: np.ndarray) -> tuple[float, float, float]:
    """(roll, pitch, yaw) in rad, ZYX, of the body->world quaternion (w, x, y, z) (4,)."""
    w, x, y, z = quat
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


class World:
    """A robot's simulated world. All quantities SI (m, rad, s, N, N m)."""

    SCENE_PATH: Path  # the robot's scene.xml
    MOTORS: tuple[str, ...] = ()  # joints driven by a motor actuator of the same name
    OVERRIDE_TARGETS: Targets = WHEEL_LEGGED  # the joints and geoms the plant overrides act on

    def __init__(self, terrain: Sequence[TerrainFeature] = (), timestep_s: float = 0.001,
                 overrides: Mapping[str, float] | None = None):
        if not (math.isfinite(timestep_s) and 0 < timestep_s <= 0.01):
            raise ValueError(f"timestep_s must be in (0, 0.01] s, got {timestep_s}")
        self.terrain = tuple(terrain)
        spec = mujoco.MjSpec.from_file(str(self.SCENE_PATH))
        spec.option.timestep = timestep_s
        self.terrain_names = add_to_spec(spec, self.terrain)
        override_model(spec, overrides or {}, self.OVERRIDE_TARGETS)
        self.spec = spec  # what was compiled (a rig trace attaches its XML when the plant is overridden)
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        self._scratch = mujoco.MjData(self.model)  # for readings that must not touch self.data
        # numpy views into MjData's C memory, cached: the attribute lookups cost
        # microseconds each and ground_truth runs every control period
        self._qpos, self._qvel, self._ctrl = self.data.qpos, self.data.qvel, self.data.ctrl
        self._kin_qpos, self._kin_site_xpos = self._scratch.qpos, self._scratch.site_xpos
        self._kin_geom_xpos, self._kin_geom_xmat = self._scratch.geom_xpos, self._scratch.geom_xmat
        self._index()
        self._force_world = np.zeros(3)
        self._force_point_body = np.zeros(3)
        self._wrench = np.zeros(6)  # scratch for mj_contactForce
        self._reset_data()
        mujoco.mj_forward(self.model, self.data)

    # -- names -> indices ------------------------------------------------------------
    def _index(self) -> None:
        """Indices of joints, motors, the body and the IMU; a subclass adds its own after these."""
        m = self.model
        self._joint_id = {m.joint(i).name: i for i in range(m.njnt)}
        self._shafts = {}
        for name in self.MOTORS:
            j = m.joint(name).id
            self._shafts[name] = (int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j]))
        self._actuator = {name: m.actuator(name).id for name in self.MOTORS}
        # the per-step path (``set_motor_torques``, ``motor_states``): indices in MOTORS order
        self._motor_ctrl = tuple(self._actuator[name] for name in self.MOTORS)
        first = self._motor_ctrl[0] if self._motor_ctrl else 0
        contiguous = self._motor_ctrl == tuple(range(first, first + len(self._motor_ctrl)))
        # one numpy assignment a step: a slice where the actuators are in MOTORS order, else their indices
        self._motor_ctrl_at = slice(first, first + len(self._motor_ctrl)) if contiguous else np.array(self._motor_ctrl)
        self._motor_shafts = tuple(self._shafts[name] for name in self.MOTORS)
        self._body = m.body("body").id
        self._com_body = m.body_ipos[self._body].copy()  # m, body frame: the nominal CoM is its origin
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

    def _set_motor_torques(self, names: tuple[str, ...], torques_nm: dict[str, float]) -> None:
        """Motor torques (N m, shaft sign) of the motors ``names`` by joint name, held until changed."""
        ctrl, actuator = self._ctrl, self._actuator
        for name, value in torques_nm.items():
            if name not in names:
                raise KeyError(f"no motor named {name!r} here; expected one of {names}")
            value = float(value)
            if not math.isfinite(value):
                raise ValueError(f"torque for {name} must be finite, got {value}")
            ctrl[actuator[name]] = value

    def set_motor_torques(self, torques_nm: Sequence[float]) -> None:
        """Every motor's torque (N m, shaft sign) in ``MOTORS`` order, held until changed.

        ``set_torques`` by position: a plant calls it every physics step, where
        building and checking the names costs more than the step's Python.
        """
        if len(torques_nm) != len(self._motor_ctrl):
            raise ValueError(f"need {len(self._motor_ctrl)} torques ({', '.join(self.MOTORS)}), got {len(torques_nm)}")
        if not all(map(math.isfinite, torques_nm)):
            name, value = next((n, v) for n, v in zip(self.MOTORS, torques_nm) if not math.isfinite(v))
            raise ValueError(f"torque for {name} must be finite, got {value}")
        self._ctrl[self._motor_ctrl_at] = torques_nm

    def apply_body_force(self, force_world_n, point_body_m=(0.0, 0.0, 0.0)) -> None:
        """Hold a force (N, world frame, (3,)) on the body at ``point_body_m`` (m, body frame, (3,)).

        It acts until changed; a zero force releases it. Its moment about the
        CoM follows the body as it turns.
        """
        force, point = np.asarray(force_world_n, dtype=float), np.asarray(point_body_m, dtype=float)
        if force.shape != (3,) or point.shape != (3,) or not (np.all(np.isfinite(force)) and np.all(np.isfinite(point))):
            raise ValueError(f"force and point must be finite 3-vectors, got {force_world_n}, {point_body_m}")
        self._force_world, self._force_point_body = force.copy(), point.copy()
        self._force_held = bool(force.any())
        if not self._force_held:
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
        held = self._force_held  # set with the force: a numpy any() per step costs ~1 us
        for _ in range(n):
            if held:
                self._update_body_force()
            mujoco.mj_step(m, d)

    # -- device readings ----------------------------------------------------------------
    def shaft_state(self, name: str) -> tuple[float, float]:
        """(angle in rad, speed in rad/s) of a motor's joint, read from ``qpos``/``qvel`` (what its
        encoder reads; the robot's physics says where each shaft's zero is)."""
        try:
            qadr, dadr = self._shafts[name]
        except KeyError:
            raise KeyError(f"no motor named {name!r}; expected one of {self.MOTORS}") from None
        return float(self._qpos[qadr]), float(self._qvel[dadr])

    def shaft_states(self, names) -> list[tuple[float, float]]:
        """``shaft_state`` of each of ``names`` (motor joints), ``qpos``/``qvel`` read once."""
        qpos, qvel, shafts = self._qpos.tolist(), self._qvel.tolist(), self._shafts
        try:
            return [(qpos[shafts[name][0]], qvel[shafts[name][1]]) for name in names]
        except KeyError as exc:
            raise KeyError(f"no motor named {exc.args[0]!r}; expected one of {self.MOTORS}") from None

    def motor_states(self) -> list[tuple[float, float]]:
        """``shaft_state`` of every motor, in ``MOTORS`` order."""
        qpos, qvel = self._qpos.tolist(), self._qvel.tolist()
        return [(qpos[q], qvel[v]) for q, v in self._motor_shafts]

    def imu_truth(self) -> tuple[tuple, tuple, tuple]:
        """``imu`` as tuples of floats: quaternion (4), gyro (3), specific force (3)."""
        s = self.data.sensordata.tolist()
        return tuple(s[self._quat_s]), tuple(s[self._gyro_s]), tuple(s[self._accel_s])

    def imu(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """IMU at its site: quaternion w,x,y,z body->world (4,), gyro rad/s body (3,),
        specific force m/s^2 body (3,) (+9.81 on z at rest). One timestep old (module doc)."""
        s = self.data.sensordata
        return s[self._quat_s].copy(), s[self._gyro_s].copy(), s[self._accel_s].copy()

    def warnings(self) -> dict[str, int]:
        """MuJoCo's warning counters that are non-zero, by mjtWarning name."""
        return {mujoco.mjtWarning(i).name: int(w.number) for i, w in enumerate(self.data.warning) if w.number}

    def pose_truth(self) -> dict[str, float]:
        """The body's pose and velocity now: t (s); x, y, z of the body frame's origin (m, world);
        roll, pitch, yaw (rad, ZYX, pitch > 0 nose down); vx, vy, vz (m/s, world); wx, wy, wz (rad/s, body)."""
        qpos, qvel = self._qpos.tolist(), self._qvel.tolist()  # whole: a slice is a new array first
        roll, pitch, yaw = euler_zyx(qpos[3:7])
        return {"t": float(self.data.time), "x": qpos[0], "y": qpos[1], "z": qpos[2],
                "roll": roll, "pitch": pitch, "yaw": yaw,
                "vx": qvel[0], "vy": qvel[1], "vz": qvel[2], "wx": qvel[3], "wy": qvel[4], "wz": qvel[5]}

    def _kinematics(self) -> mujoco.MjData:
        """The scratch data with positions of the current state."""
        self._kin_qpos[:] = self._qpos
        mujoco.mj_kinematics(self.model, self._scratch)
        return self._scratch

    # -- resets -----------------------------------------------------------------------------
    def _reset_data(self) -> None:
        mujoco.mj_resetData(self.model, self.data)
        self._force_world[:] = 0.0
        self._force_held = False
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
