"""Terrain and obstacles added to the scene: steps, slopes, ramps, bumps, walls, projectiles.

A ``TerrainFeature`` describes one feature in world coordinates (m, rad; x
forward from the robot's default start at the origin, y left, z up, the floor
at z = 0); ``add_to_spec`` puts it into a ``mujoco.MjSpec`` of scene.xml.

Ground features (everything but projectiles) are static geoms in geom group 0,
as the floor is, so ``Physics`` finds "the ground below" a wheel by casting rays
at group 0 only. Projectiles are free bodies in group 1. Every feature's geoms
touch the robot's wheels and body box (contype/conaffinity 1, see robot.xml).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import mujoco

KINDS = ("step", "slope", "ramp", "bump", "wall", "projectile")
GROUND_GROUP = 0
PROJECTILE_GROUP = 1
_FRICTION = (1.0, 0.005, 0.0001)  # sliding, torsional, rolling: as the floor
_RGBA = (0.55, 0.5, 0.45, 1.0)
_BELOW_M = 0.2  # how far a ground box reaches under the floor, so no gap opens
_DEFAULT_LENGTH = {"step": 5.0, "slope": 6.0, "ramp": 1.0, "bump": 0.1, "wall": 0.1}
_DEFAULT_WIDTH = {"step": 4.0, "slope": 2.0, "ramp": 2.0, "bump": 0.1, "wall": 2.0}


@dataclass(frozen=True)
class TerrainFeature:
    """One terrain feature or obstacle. Use the class methods to build them.

    kind        "step" | "slope" | "ramp" | "bump" | "wall" | "projectile"
    x_m         step: the edge; slope, ramp: where the region starts; bump: its
                centre; wall: its near face
    y_m         centre across the track (bump, slope, ramp, wall, step)
    height_m    step: rise (> 0, up onto a platform beyond x_m) or drop (< 0,
                off a platform that ends at x_m); bump, wall: top above the floor
    angle_rad   slope: tilt about +x, > 0 raises the left (+y) side; ramp:
                incline, rising along +x
    length_m    extent along x (None: a default per kind); for a ramp, its
                horizontal run, followed by a 5 m plateau at the top
    width_m     extent along y (None: a default per kind)
    shape       bump: "box", or "cylinder" (lying across, axis along y, radius
                length_m / 2, its top at height_m)
    mass_kg, radius_m, position_m (3,), velocity_mps (3,): projectile, a solid
                sphere with that initial centre and velocity (world) at reset
    """

    kind: str
    x_m: float = 0.0
    y_m: float = 0.0
    height_m: float = 0.0
    angle_rad: float = 0.0
    length_m: float | None = None
    width_m: float | None = None
    shape: str = "box"
    mass_kg: float = 0.0
    radius_m: float = 0.0
    position_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    velocity_mps: tuple[float, float, float] = (0.0, 0.0, 0.0)
    friction: float = field(default=_FRICTION[0])

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"unknown terrain kind {self.kind!r}; expected one of {KINDS}")
        for name in ("x_m", "y_m", "height_m", "angle_rad", "mass_kg", "radius_m", "friction"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{self.kind}: {name} must be finite, got {getattr(self, name)}")
        for name in ("length_m", "width_m"):
            value = getattr(self, name)
            if value is not None and not (math.isfinite(value) and value > 0):
                raise ValueError(f"{self.kind}: {name} must be > 0, got {value}")
        if self.friction <= 0:
            raise ValueError(f"{self.kind}: friction must be > 0, got {self.friction}")
        _CHECKS[self.kind](self)

    @property
    def length(self) -> float:
        """Extent along x (m), the given one or the kind's default."""
        return self.length_m if self.length_m is not None else _DEFAULT_LENGTH.get(self.kind, 0.0)

    @property
    def width(self) -> float:
        """Extent along y (m), the given one or the kind's default."""
        return self.width_m if self.width_m is not None else _DEFAULT_WIDTH.get(self.kind, 0.0)

    # -- builders ---------------------------------------------------------------
    @classmethod
    def step(cls, x_m: float, height_m: float, **kw) -> TerrainFeature:
        """A step edge at x_m: up onto a platform (height_m > 0) or down off one (< 0)."""
        return cls("step", x_m=x_m, height_m=height_m, **kw)

    @classmethod
    def slope(cls, angle_rad: float, x_m: float = -3.0, length_m: float = 6.0, width_m: float = 2.0,
              **kw) -> TerrainFeature:
        """A side slope (tilted about x) over x_m .. x_m + length_m; the default spans the origin."""
        return cls("slope", x_m=x_m, angle_rad=angle_rad, length_m=length_m, width_m=width_m, **kw)

    @classmethod
    def ramp(cls, x_m: float, angle_rad: float, length_m: float = 1.0, **kw) -> TerrainFeature:
        """An incline rising along +x from x_m over a run of length_m, then a plateau."""
        return cls("ramp", x_m=x_m, angle_rad=angle_rad, length_m=length_m, **kw)

    @classmethod
    def bump(cls, x_m: float, y_m: float, height_m: float, shape: str = "box", **kw) -> TerrainFeature:
        """A bump of height_m centred at (x_m, y_m), e.g. under one wheel (y = +-HALF_TRACK)."""
        return cls("bump", x_m=x_m, y_m=y_m, height_m=height_m, shape=shape, **kw)

    @classmethod
    def wall(cls, x_m: float, height_m: float, **kw) -> TerrainFeature:
        """A wall across the track whose near face is at x_m."""
        return cls("wall", x_m=x_m, height_m=height_m, **kw)

    @classmethod
    def projectile(cls, mass_kg: float, radius_m: float, position_m, velocity_mps) -> TerrainFeature:
        """A free solid sphere, launched from position_m at velocity_mps at every reset."""
        return cls("projectile", mass_kg=mass_kg, radius_m=radius_m,
                   position_m=tuple(float(v) for v in position_m),
                   velocity_mps=tuple(float(v) for v in velocity_mps))


# -- validation -------------------------------------------------------------------
def _check_step(f: TerrainFeature) -> None:
    if f.height_m == 0:
        raise ValueError("step: height_m must be non-zero (> 0 up, < 0 down)")


def _check_slope(f: TerrainFeature) -> None:
    if not 0 < abs(f.angle_rad) < math.radians(60):
        raise ValueError(f"slope: |angle_rad| must be in (0, 60 deg), got {f.angle_rad}")


def _check_ramp(f: TerrainFeature) -> None:
    if not 0 < f.angle_rad < math.radians(60):
        raise ValueError(f"ramp: angle_rad must be in (0, 60 deg), got {f.angle_rad}")


def _check_bump(f: TerrainFeature) -> None:
    if f.height_m <= 0:
        raise ValueError(f"bump: height_m must be > 0, got {f.height_m}")
    if f.shape not in ("box", "cylinder"):
        raise ValueError(f"bump: shape must be 'box' or 'cylinder', got {f.shape!r}")


def _check_wall(f: TerrainFeature) -> None:
    if f.height_m <= 0:
        raise ValueError(f"wall: height_m must be > 0, got {f.height_m}")


def _check_projectile(f: TerrainFeature) -> None:
    if not (f.mass_kg > 0 and f.radius_m > 0):
        raise ValueError(f"projectile: mass_kg and radius_m must be > 0, got {f.mass_kg}, {f.radius_m}")
    for name in ("position_m", "velocity_mps"):
        value = getattr(f, name)
        if len(value) != 3 or not all(math.isfinite(v) for v in value):
            raise ValueError(f"projectile: {name} must be 3 finite numbers, got {value}")


_CHECKS = {"step": _check_step, "slope": _check_slope, "ramp": _check_ramp, "bump": _check_bump,
           "wall": _check_wall, "projectile": _check_projectile}


# -- building ----------------------------------------------------------------------
def _quat_about(axis: int, angle: float) -> list[float]:
    """Unit quaternion (w, x, y, z) of a rotation by ``angle`` rad about world axis 0/1/2."""
    q = [math.cos(angle / 2), 0.0, 0.0, 0.0]
    q[1 + axis] = math.sin(angle / 2)
    return q


def _ground_box(spec: mujoco.MjSpec, name: str, f: TerrainFeature, centre, half_size, quat=(1, 0, 0, 0)):
    spec.worldbody.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_BOX, pos=list(centre),
                            size=list(half_size), quat=list(quat), group=GROUND_GROUP,
                            friction=[f.friction, *_FRICTION[1:]], condim=3, rgba=list(_RGBA))


def _tilted_box(spec, name, f, top_centre, half_x, half_y, axis, angle):
    """A box whose top face is centred at ``top_centre`` and tilted by ``angle`` about ``axis``.

    It is thick enough to reach below the floor under all of its top face.
    """
    across = 2.0 * (half_y if axis == 0 else half_x)
    half_z = (abs(math.sin(angle)) * across + _BELOW_M) / math.cos(angle)
    # the top face's normal, rotated with the box
    if axis == 0:
        normal = (0.0, -math.sin(angle), math.cos(angle))
    else:
        normal = (math.sin(angle), 0.0, math.cos(angle))
    centre = [top_centre[i] - half_z * normal[i] for i in range(3)]
    _ground_box(spec, name, f, centre, (half_x, half_y, half_z), _quat_about(axis, angle))


def _add_step(spec, name, f):
    h = abs(f.height_m)
    x0 = f.x_m if f.height_m > 0 else f.x_m - f.length  # platform beyond (up) or before (down) the edge
    _ground_box(spec, name, f, (x0 + f.length / 2, f.y_m, (h - _BELOW_M) / 2),
                (f.length / 2, f.width / 2, (h + _BELOW_M) / 2))


def _add_slope(spec, name, f):
    # lowest edge on the floor, rising across y: top centre at (w/2) tan|a|
    rise = 0.5 * f.width * math.tan(abs(f.angle_rad))
    half_y = 0.5 * f.width / math.cos(f.angle_rad)
    _tilted_box(spec, name, f, (f.x_m + f.length / 2, f.y_m, rise), f.length / 2, half_y, 0, f.angle_rad)


def _add_ramp(spec, name, f):
    run, a = f.length, f.angle_rad
    top = run * math.tan(a)
    # rotation about +y tips +x down, so a rising ramp turns by -a about y
    _tilted_box(spec, name, f, (f.x_m + run / 2, f.y_m, top / 2), 0.5 * run / math.cos(a), f.width / 2, 1, -a)
    plateau = 5.0
    _ground_box(spec, f"{name}_plateau", f, (f.x_m + run + plateau / 2, f.y_m, (top - _BELOW_M) / 2),
                (plateau / 2, f.width / 2, (top + _BELOW_M) / 2))


def _add_bump(spec, name, f):
    if f.shape == "box":
        _ground_box(spec, name, f, (f.x_m, f.y_m, f.height_m / 2), (f.length / 2, f.width / 2, f.height_m / 2))
        return
    r = f.length / 2
    spec.worldbody.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_CYLINDER, pos=[f.x_m, f.y_m, f.height_m - r],
                            size=[r, f.width / 2, 0], quat=_quat_about(0, math.pi / 2), group=GROUND_GROUP,
                            friction=[f.friction, *_FRICTION[1:]], condim=3, rgba=list(_RGBA))


def _add_wall(spec, name, f):
    _ground_box(spec, name, f, (f.x_m + f.length / 2, f.y_m, f.height_m / 2),
                (f.length / 2, f.width / 2, f.height_m / 2))


def _add_projectile(spec, name, f):
    body = spec.worldbody.add_body(name=name, pos=list(f.position_m))
    body.add_freejoint(name=name)
    body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[f.radius_m, 0, 0], mass=f.mass_kg,
                  group=PROJECTILE_GROUP, friction=[f.friction, *_FRICTION[1:]], condim=3,
                  rgba=[0.8, 0.2, 0.2, 1.0])


_BUILDERS = {"step": _add_step, "slope": _add_slope, "ramp": _add_ramp, "bump": _add_bump,
             "wall": _add_wall, "projectile": _add_projectile}


def feature_name(index: int, feature: TerrainFeature) -> str:
    """The MJCF name of feature number ``index`` (its geom; for a projectile also body and joint)."""
    return f"terrain{index}_{feature.kind}"


def add_to_spec(spec: mujoco.MjSpec, features) -> list[str]:
    """Add ``features`` to ``spec``'s world body; returns their names, in order."""
    names = []
    for i, f in enumerate(features):
        if not isinstance(f, TerrainFeature):
            raise TypeError(f"terrain entries must be TerrainFeature, got {type(f).__name__}")
        names.append(feature_name(i, f))
        _BUILDERS[f.kind](spec, names[-1], f)
    return names
