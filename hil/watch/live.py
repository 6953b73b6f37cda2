"""``--live``: the run streamed over the Foxglove WebSocket protocol while it goes (Foxglove SDK's server).

Channels (the trace's where it has them, with the same schemas and bytes):

- ``/scene``              foxglove.SceneUpdate (protobuf), every ``SCENE_PERIOD_S`` of simulated
                          time: the MJCF's geoms posed, ground and terrain, contact forces (foxglove_scene.py)
- ``/sim/state``          ground truth every control period (JSON)
- ``/controller/debug``   the in-process controller's signals every period (JSON)
- ``/can/<channel>``      every frame, one message per bus and 100 ms as in the trace (CDR, ros2msg)
- ``/scenario/events``    each event as it happens (JSON)

The server has its own ``foxglove.Context``: nothing of it reaches the trace,
and a run without ``--live`` imports none of it. Log times are the run's
simulated time (ns), as in the trace; the server broadcasts that time too, so
Foxglove's clock follows the run.
"""
from __future__ import annotations

import time

import foxglove

from wheelleg.hil.record import can_batch, schemas
from wheelleg.hil.record.schemas import CAN_PREFIX, EVENTS_TOPIC, SIM_STATE_TOPIC
from wheelleg.hil.record.trace_json import dumps
from wheelleg.hil.watch.foxglove_scene import SceneBuilder
from wheelleg.hil.watch.options import WatchError
from wheelleg.hil.watch.scene_record import SCENE_PERIOD_S, SCENE_TOPIC

DEBUG_TOPIC = "/controller/debug"
DRAIN_S = 1.0  # s a subscribed client has, at the end, to take the last messages
CAN_WINDOW_NS = 100_000_000  # each bus's frames of 100 ms of bus time are one /can/ message, as in the trace


def _json_channel(context, topic: str, schema: dict) -> foxglove.Channel:
    return foxglove.Channel(topic, message_encoding="json", context=context,
                            schema=foxglove.Schema(name=schema.get("title", topic), encoding="jsonschema",
                                                   data=schemas.schema_bytes(schema)))


class LiveServer:
    """The Foxglove WebSocket server as a rig watcher (``Rig.watchers``) and a frame sink of its recorder."""

    def __init__(self, rig, host: str, port: int, wait_s: float = 0.0):
        """``wait_s``: hold the run's start until a client subscribes to /scene, at most this long (s)."""
        self.context = foxglove.Context()
        try:
            self.server = foxglove.start_server(name=f"wheelleg {rig.scenario.name}", host=host, port=port,
                                                context=self.context, capabilities=[foxglove.Capability.Time])
        except Exception as exc:  # noqa: BLE001 - the SDK's own error (address in use, bad host), one line
            raise WatchError(f"--live: cannot listen on {host}:{port}: {exc}".splitlines()[0]) from exc
        self.url = f"ws://{host}:{self.server.port}"
        self.scene = SceneBuilder(rig.physics.model)
        self._scene_period_ns = round(SCENE_PERIOD_S * 1e9)
        self._next_scene_ns = 0
        self._channels = {name: self._can_channel(name) for name in rig.names.values()}  # advertised at once
        self._windows: dict[str, tuple[int, list]] = {}  # CAN channel -> (window index, its frames)
        self._scene = foxglove.channels.SceneUpdateChannel(SCENE_TOPIC, context=self.context)
        fields = rig.robot.sim_state_fields or schemas.SIM_STATE_FIELDS
        extra = [k for k in rig.physics.ground_truth() if k not in fields]
        self._state = _json_channel(self.context, SIM_STATE_TOPIC, schemas.sim_state_schema(extra, fields))
        self._debug = (_json_channel(self.context, DEBUG_TOPIC, rig.robot.debug_schema)
                       if rig.robot.debug_schema is not None and rig.controller is not None else None)
        self._events = _json_channel(self.context, EVENTS_TOPIC, schemas.EVENT)
        rig.recorder.sinks.append(self)
        self._rig = rig
        self._record_event = rig.trace.event
        rig.trace.event = self._event  # the trace's events, and each one here as it comes
        print(f"live: Foxglove WebSocket at {self.url} (open it in the Foxglove app; its layout: `wheelleg layout`)",
              flush=True)
        if wait_s > 0:
            self._wait_for_client(wait_s)

    def _wait_for_client(self, wait_s: float) -> None:
        print(f"live: the run starts when a client subscribes to {SCENE_TOPIC} (at most {wait_s:g} s)", flush=True)
        deadline = time.monotonic() + wait_s
        while not self._scene.has_sinks() and time.monotonic() < deadline:
            time.sleep(0.05)

    # -- a rig watcher ------------------------------------------------------------------
    def on_state(self, rig, state: dict) -> None:
        t_ns = rig.clock.now_ns
        self._state.log(dumps(state), log_time=t_ns)
        if self._debug is not None:
            result = rig.controller.last_result
            if result is not None and result.debug:
                self._debug.log(dumps(result.debug), log_time=t_ns)
        if t_ns >= self._next_scene_ns:
            self._next_scene_ns = (t_ns // self._scene_period_ns + 1) * self._scene_period_ns
            self._scene.log(self.scene.update(rig.physics.data, t_ns), log_time=t_ns)
            self.server.broadcast_time(t_ns)

    def _event(self, t_ns: int, kind: str, **fields) -> None:
        self._record_event(t_ns, kind, **fields)
        self._events.log(dumps({"kind": kind, **fields}), log_time=t_ns)

    # -- a recorder sink ----------------------------------------------------------------
    def on_frames(self, frames: list) -> None:
        """Frames in time order: each bus's 100 ms windows, published as each one ends."""
        windows = self._windows
        for frame in frames:
            window = frame.t_ns // CAN_WINDOW_NS
            held = windows.get(frame.channel)
            if held is None or held[0] != window:
                if held is not None:
                    self._publish(frame.channel, held[1])
                held = windows[frame.channel] = (window, [])
            held[1].append(frame)

    def _can_channel(self, channel: str) -> foxglove.Channel:
        return foxglove.Channel(CAN_PREFIX + channel, message_encoding=schemas.CAN_FRAME_MESSAGE_ENCODING,
                                context=self.context,
                                schema=foxglove.Schema(name=schemas.CAN_FRAMES_NAME, encoding=schemas.CAN_FRAME_ENCODING,
                                                       data=schemas.CAN_FRAMES_MSG.encode()))

    def _publish(self, channel: str, frames: list) -> None:
        out = self._channels.get(channel) or self._channels.setdefault(channel, self._can_channel(channel))
        out.log(can_batch.pack(frames), log_time=frames[0].t_ns)

    def stop(self) -> None:
        """The recorder's end: the last windows."""
        for channel, (_, frames) in self._windows.items():
            if frames:
                self._publish(channel, frames)
        self._windows = {}

    def close(self) -> None:
        """Stop serving; a subscribed client first gets DRAIN_S to take what is queued (the
        SDK sends from its own thread and its stop drops what is still queued: the last
        /scene message went missing under load)."""
        self._rig.trace.event = self._record_event
        if self._scene.has_sinks():
            time.sleep(DRAIN_S)
        self.server.stop()
