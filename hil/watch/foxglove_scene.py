"""The MuJoCo world as a Foxglove 3D scene (``foxglove.SceneUpdate``): geoms posed, contact forces as arrows.

Three entities in frame ``world``: ``world`` (the ground, terrain and obstacles:
geoms of MuJoCo's world body), ``robot`` (every other geom: the robot and any
projectile) and ``contacts`` (one arrow per contact, along the force on the
robot, ``ARROW_M_PER_N`` long per newton). Boxes, spheres, ellipsoids, cylinders
and capsules (a cylinder and two spheres) map to Foxglove's primitives; a plane
is drawn as a thin ``PLANE_SIZE_M`` square; meshes and height fields are left out.
Every update carries all three entities, so a viewer that joins late has the
whole scene from its first message.
"""
from __future__ import annotations

import math

import mujoco
import numpy as np
from foxglove import messages as fm

ARROW_M_PER_N = 0.005  # arrow length per newton of contact force (50 N: 0.25 m)
ARROW_MOST_M = 0.5
PLANE_SIZE_M = 20.0  # an infinite MuJoCo plane drawn this wide
_T = mujoco.mjtGeom


_Q = np.empty(4)  # scratch quaternion (w, x, y, z)


def _pose(position, xmat: np.ndarray) -> fm.Pose:
    mujoco.mju_mat2Quat(_Q, xmat)
    w, qx, qy, qz = _Q.tolist()
    x, y, z = position.tolist()
    return fm.Pose(position=fm.Vector3(x=x, y=y, z=z), orientation=fm.Quaternion(x=qx, y=qy, z=qz, w=w))


class SceneBuilder:
    """Builds a ``SceneUpdate`` of a model's state, reusing what never changes (sizes, colours, groups)."""

    def __init__(self, model: mujoco.MjModel):
        self.model = model
        self._colour = [self._geom_colour(g) for g in range(model.ngeom)]
        self._shapes = [self._shape(g) for g in range(model.ngeom)]  # sizes never change: made once
        self._balls = {g: fm.Vector3(x=2 * model.geom_size[g][0], y=2 * model.geom_size[g][0], z=2 * model.geom_size[g][0])
                       for g in range(model.ngeom) if model.geom_type[g] == _T.mjGEOM_CAPSULE}
        self._static = [g for g in range(model.ngeom) if model.geom_bodyid[g] == 0]
        self._moving = [g for g in range(model.ngeom) if model.geom_bodyid[g] != 0]
        self._force = np.zeros(6)
        self._posed = mujoco.MjData(model)  # the geoms at the state's qpos (``data``'s own are a step old)

    def _geom_colour(self, g: int) -> fm.Color:
        m = self.model
        r, gr, b, a = (m.mat_rgba[m.geom_matid[g]] if m.geom_matid[g] >= 0 else m.geom_rgba[g]).tolist()
        return fm.Color(r=r, g=gr, b=b, a=a)

    def update(self, data: mujoco.MjData, t_ns: int) -> fm.SceneUpdate:
        """The scene at ``data``'s state (geoms at its qpos, the contacts of its last step), stamped ``t_ns``."""
        stamp = fm.Timestamp(t_ns // 1_000_000_000, t_ns % 1_000_000_000)
        posed = self._posed
        posed.qpos[:] = data.qpos
        mujoco.mj_kinematics(self.model, posed)  # after mj_step, data's geom poses are those it started from
        entities = [self._entity("world", self._static, posed, stamp), self._entity("robot", self._moving, posed, stamp),
                    fm.SceneEntity(timestamp=stamp, frame_id="world", id="contacts", arrows=self._arrows(data))]
        return fm.SceneUpdate(entities=entities)

    def _entity(self, name: str, geoms: list[int], data: mujoco.MjData, stamp) -> fm.SceneEntity:
        parts: dict[str, list] = {"cubes": [], "spheres": [], "cylinders": []}
        for g in geoms:
            self._add_geom(parts, g, data)
        return fm.SceneEntity(timestamp=stamp, frame_id="world", id=name, **parts)

    def _shape(self, g: int):
        """(primitive list name, size, capsule half length or 0) of geom ``g``; None for a mesh or height field."""
        m = self.model
        kind, size = m.geom_type[g], m.geom_size[g].tolist()
        if kind == _T.mjGEOM_BOX:
            return "cubes", fm.Vector3(x=2 * size[0], y=2 * size[1], z=2 * size[2]), 0.0
        if kind == _T.mjGEOM_PLANE:
            wide = [2 * s if s > 0 else PLANE_SIZE_M for s in size[:2]]
            return "cubes", fm.Vector3(x=wide[0], y=wide[1], z=0.001), 0.0
        if kind in (_T.mjGEOM_SPHERE, _T.mjGEOM_ELLIPSOID):
            radii = size if kind == _T.mjGEOM_ELLIPSOID else [size[0]] * 3
            return "spheres", fm.Vector3(x=2 * radii[0], y=2 * radii[1], z=2 * radii[2]), 0.0
        if kind in (_T.mjGEOM_CYLINDER, _T.mjGEOM_CAPSULE):
            half = size[1] if kind == _T.mjGEOM_CAPSULE else 0.0
            return "cylinders", fm.Vector3(x=2 * size[0], y=2 * size[0], z=2 * size[1]), half
        return None

    def _add_geom(self, parts: dict, g: int, data: mujoco.MjData) -> None:
        shape = self._shapes[g]
        if shape is None:
            return
        kind, size, capsule_half = shape
        colour, xmat, pos = self._colour[g], data.geom_xmat[g], data.geom_xpos[g]
        pose = _pose(pos, xmat)
        if kind == "cylinders":
            parts[kind].append(fm.CylinderPrimitive(pose=pose, size=size, color=colour, bottom_scale=1.0, top_scale=1.0))
        elif kind == "cubes":
            parts[kind].append(fm.CubePrimitive(pose=pose, size=size, color=colour))
        else:
            parts[kind].append(fm.SpherePrimitive(pose=pose, size=size, color=colour))
        if capsule_half:  # a capsule's round ends
            ball = self._balls[g]
            axis = xmat.reshape(3, 3)[:, 2] * capsule_half
            for end in (pos + axis, pos - axis):
                parts["spheres"].append(fm.SpherePrimitive(pose=_pose(end, xmat), size=ball, color=colour))

    def _arrows(self, data: mujoco.MjData) -> list:
        """One arrow per contact: the force on the geom of the higher body id (the robot's side), from the
        contact point."""
        arrows = []
        for i in range(data.ncon):
            contact = data.contact[i]
            mujoco.mj_contactForce(self.model, data, i, self._force)
            frame = contact.frame.reshape(3, 3)
            force = frame.T @ self._force[:3]  # contact frame -> world: the force of geom 1 on geom 2
            if self.model.geom_bodyid[contact.geom[0]] > self.model.geom_bodyid[contact.geom[1]]:
                force = -force
            newtons = float(np.linalg.norm(force))
            if newtons < 1e-6:
                continue
            length = min(ARROW_MOST_M, newtons * ARROW_M_PER_N)
            arrows.append(fm.ArrowPrimitive(pose=fm.Pose(position=fm.Vector3(**dict(zip("xyz", contact.pos.tolist()))),
                                                         orientation=_x_towards(force / newtons)),
                                            shaft_length=0.8 * length, shaft_diameter=0.006,
                                            head_length=0.2 * length, head_diameter=0.015,
                                            color=fm.Color(r=1.0, g=0.2, b=0.1, a=1.0)))
        return arrows


def _x_towards(direction: np.ndarray) -> fm.Quaternion:
    """The rotation taking +x to the unit vector ``direction`` (an arrow points along its +x)."""
    x, y, z = direction.tolist()
    w = 1.0 + x  # q = (1 + x.d, x cross d), normalised
    if w < 1e-9:  # pointing along -x: half a turn about z
        return fm.Quaternion(x=0.0, y=0.0, z=1.0, w=0.0)
    norm = math.sqrt(w * w + z * z + y * y)
    return fm.Quaternion(x=0.0, y=-z / norm, z=y / norm, w=w / norm)
