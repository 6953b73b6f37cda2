"""The robot's pose in a trace (``/sim/qpos``) and the MuJoCo world it was recorded in.

Every run records MuJoCo's whole generalized position (``qpos``: free bodies as
x, y, z and a quaternion, hinges as angles) every ``QPOS_PERIOD_S`` of simulated
time, one float64 per coordinate, so any run can be drawn again from its trace
alone (``wheelleg render``, the filmstrip of the run's PNG). 25 Hz: a video's rate;
~3.7 KB per simulated second, 1.5 % of a balance trace (docs/measurements.md).

The world: the MJCF the run compiled when the plant was overridden (its
``plant_model.xml`` attachment), else the robot's scene rebuilt with the
scenario's terrain (the trace's ``run`` record names both).
"""
from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from wheelleg.hil.record.schemas import described_schema

QPOS_TOPIC = "/sim/qpos"
QPOS_PERIOD_S = 0.04  # 25 Hz of simulated time: a 25 fps video's rate
_FREE_PARTS = (("x", "m, world"), ("y", "m, world"), ("z", "m, world"),
               ("qw", "orientation quaternion"), ("qx", "orientation quaternion"),
               ("qy", "orientation quaternion"), ("qz", "orientation quaternion"))
_BALL_PARTS = (("qw", ""), ("qx", ""), ("qy", ""), ("qz", ""))


class SceneError(Exception):
    """A trace that cannot be drawn (no /sim/qpos, a model that does not match): one line."""


def qpos_fields(model: mujoco.MjModel) -> dict[str, str]:
    """Field name -> description, one per qpos coordinate in qpos order (``model.nq`` of them)."""
    fields: dict[str, str] = {}
    for j in range(model.njnt):
        name = model.joint(j).name or f"joint{j}"
        kind = model.jnt_type[j]
        if kind == mujoco.mjtJoint.mjJNT_FREE:
            fields.update({f"{name}_{p}": f"[{note}] qpos of free joint {name}" for p, note in _FREE_PARTS})
        elif kind == mujoco.mjtJoint.mjJNT_BALL:
            fields.update({f"{name}_{p}": f"qpos of ball joint {name}" for p, _ in _BALL_PARTS})
        else:
            unit = "m" if kind == mujoco.mjtJoint.mjJNT_SLIDE else "rad"
            fields[name] = f"[{unit}] qpos of joint {name}"
    return fields


class QposRecorder:
    """Writes ``/sim/qpos`` into a trace every ``QPOS_PERIOD_S`` of simulated time (the rig calls ``maybe``)."""

    def __init__(self, model: mujoco.MjModel, qpos: np.ndarray):
        """``qpos``: the live MjData.qpos view, shape (nq,)."""
        fields = qpos_fields(model)
        self.schema = described_schema("wheelleg.SimQpos", fields)
        self.schema["description"] = "MuJoCo qpos of the plant, for drawing the run again"
        self._names = tuple(fields)
        self._qpos = qpos
        self._period_ns = round(QPOS_PERIOD_S * 1e9)
        self._next_ns = 0

    def maybe(self, trace, t_ns: int) -> None:
        """The pose at ``t_ns`` into ``trace`` if one is due (first at t = 0 or the first call)."""
        if t_ns < self._next_ns:
            return
        self._next_ns = (t_ns // self._period_ns + 1) * self._period_ns
        trace.numbers(QPOS_TOPIC, t_ns, dict(zip(self._names, self._qpos.tolist())), self.schema)


@dataclass
class RecordedMotion:
    """A trace's poses: ``t_s`` (n,) s and ``qpos`` (n, nq), with the world they belong to, its events
    and its ground truth (``state``: /sim/state's columns)."""

    model: mujoco.MjModel
    t_s: np.ndarray
    qpos: np.ndarray
    events: list[dict]
    scenario: str
    state: dict

    def index_at(self, t_s: float) -> int:
        """The last pose at or before ``t_s`` (the first one before the first)."""
        return max(0, int(np.searchsorted(self.t_s, t_s, side="right")) - 1)


def world_model(metadata: dict, attachments: dict) -> mujoco.MjModel:
    """The MuJoCo model a trace was recorded in (module doc); SceneError if it cannot be made."""
    run = metadata.get("run", {})
    xml = attachments.get("plant_model.xml")
    if xml is not None:
        try:
            return mujoco.MjModel.from_xml_string(xml.decode())
        except (ValueError, UnicodeDecodeError) as exc:
            raise SceneError(f"its plant_model.xml does not compile: {exc}") from exc
    from wheelleg.hil import robots, scenarios  # noqa: PLC0415 (the registries only for a nominal plant)

    name, robot = run.get("scenario"), run.get("robot") or robots.DEFAULT
    try:
        scenario = scenarios.get(name, robot)
    except KeyError as exc:
        raise SceneError(f"its scenario {name!r} is not registered (its terrain is unknown): {exc}") from exc
    physics_dt_s = float(run.get("physics_dt_s") or 0.001)
    return robots.get(robot).build_physics(scenario.terrain, physics_dt_s, None).model


def recorded_motion(path) -> RecordedMotion:
    """The poses and world of the trace at ``path``; SceneError (one line) if it has none."""
    from mcap.writer import MCAP0_MAGIC  # noqa: PLC0415

    from wheelleg.hil.record.trace_reader import TraceReader  # noqa: PLC0415 (not sources: no DBC parsing)

    with open(path, "rb") as f:
        if f.read(len(MCAP0_MAGIC)) != MCAP0_MAGIC:
            raise SceneError("not an MCAP trace (a candump log holds frames only, no poses)")
    try:
        reader = TraceReader(path)
    except Exception as exc:  # noqa: BLE001 - any unreadable file is one line
        raise SceneError(f"not a readable MCAP trace: {exc}") from exc
    columns = reader.columns(QPOS_TOPIC)
    if not columns:
        raise SceneError(f"no {QPOS_TOPIC} in it (recorded by runs since the renderer came; rerun the scenario)")
    model = world_model(reader.metadata, reader.attachments)
    names = list(qpos_fields(model))
    missing = [n for n in names if n not in columns]
    if missing or len(names) != model.nq:
        raise SceneError(f"its {QPOS_TOPIC} does not match the world's joints (missing {missing[:3]})")
    qpos = np.column_stack([columns[n] for n in names])
    t_s = np.array([t for t, _ in reader.records(QPOS_TOPIC)], dtype=np.int64) / 1e9
    return RecordedMotion(model, t_s, qpos, reader.events(),
                          reader.metadata.get("run", {}).get("scenario", "run"), reader.sim_state())
