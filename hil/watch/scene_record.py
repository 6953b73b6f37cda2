"""``--scene``: the live server's /scene topic (foxglove.SceneUpdate, protobuf) recorded into the trace too,
so Foxglove's 3D panel shows the robot when the trace is opened later.

Opt-in: at 50 Hz it adds ~11 kB per simulated second (zstd) to a balance trace's ~240 kB (+5 %), and
~0.4 ms of CPU per scene (tools/watch_cost.py); ``wheelleg render`` needs only /sim/qpos, which every
run records.
"""
from __future__ import annotations

from foxglove import messages as fm
from mcap.records import Schema

from wheelleg.hil.watch.foxglove_scene import SceneBuilder

SCENE_TOPIC = "/scene"
SCENE_PERIOD_S = 0.02  # 50 Hz of simulated time, live and recorded


class SceneRecorder:
    """Writes /scene into the rig's trace every ``SCENE_PERIOD_S`` (a rig watcher)."""

    def __init__(self, rig):
        schema = fm.SceneUpdate.get_schema()
        self.builder = SceneBuilder(rig.physics.model)
        self._channel = rig.trace.copy_channel(SCENE_TOPIC, Schema(id=0, name=schema.name, encoding=schema.encoding,
                                                                           data=schema.data),
                                               schema.encoding)
        self._period_ns = round(SCENE_PERIOD_S * 1e9)
        self._next_ns = 0

    def on_state(self, rig, state: dict) -> None:
        t_ns = rig.clock.now_ns
        if t_ns >= self._next_ns:
            self._next_ns = (t_ns // self._period_ns + 1) * self._period_ns
            rig.trace.copy(self._channel, t_ns, self.builder.update(rig.physics.data, t_ns).encode())

    def close(self) -> None:
        pass
