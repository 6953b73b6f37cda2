"""``wheelleg run --live``: a Foxglove WebSocket client connects while the run goes, sees the channels
advertised and receives scene updates whose poses are the plant's (the trace's /sim/qpos), ground truth
and the frames the trace has."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import foxglove_client
from wheelleg.hil.record import can_batch
from wheelleg.hil.record.trace import TraceReader
from wheelleg.hil.watch.scene import recorded_motion

pytestmark = pytest.mark.slow
BODY_BOX_SIZE = (0.26, 0.24, 0.08)  # emulators/robot/robot.xml: body_box half sizes 0.13 0.12 0.04


def body_box(update) -> tuple[np.ndarray, np.ndarray]:
    """The body box's (position (3,), quaternion w, x, y, z (4,)) in a decoded SceneUpdate."""
    robot = next(e for e in update.entities if e.id == "robot")
    cube = next(c for c in robot.cubes if np.allclose([c.size.x, c.size.y, c.size.z], BODY_BOX_SIZE))
    p, q = cube.pose.position, cube.pose.orientation
    return np.array([p.x, p.y, p.z]), np.array([q.w, q.x, q.y, q.z])


def receive(client: foxglove_client.Client) -> dict:
    """Topic -> [(log time ns, payload)] of everything the run streams from now on; "scene_class": /scene's."""
    topics = {"/scene", "/sim/state", "/controller/debug", "/scenario/events", "/can/vcan0", "/can/vcan1"}
    channels = client.wait_for_channels(topics)
    assert channels["/scene"]["schemaName"] == "foxglove.SceneUpdate"
    assert channels["/scene"]["encoding"] == "protobuf" and channels["/can/vcan0"]["encoding"] == "cdr"
    client.subscribe(sorted(topics))
    got: dict = {topic: [] for topic in topics}
    for topic, t_ns, payload in client.messages():
        got[topic].append((t_ns, payload))
    got["scene_class"] = client.protobuf_class("/scene")
    return got


def test_a_client_sees_the_channels_and_scene_poses_that_match_ground_truth(tmp_path):
    run = subprocess.Popen([sys.executable, "-m", "wheelleg.hil.cli", "run", "balance", "--live", "--port", "0",
                            "--live-wait", "60", "--out", str(tmp_path), "--no-plot", "-q"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = run.stdout.readline()
        assert line.startswith("live: Foxglove WebSocket at ws://127.0.0.1:"), line
        with foxglove_client.Client(line.split(" at ")[1].split()[0]) as client:
            got = receive(client)
        out, err = run.communicate(timeout=120)
    finally:
        run.kill()
    assert run.returncode == 0, err
    # every message from the start (--live-wait): scenes at 2 ms, then every 20 ms to 10 s; the state every tick
    assert [t for t, _ in got["/scene"][:2]] == [2_000_000, 20_000_000] and len(got["/scene"]) == 501
    assert len(got["/sim/state"]) == 5000 and got["/can/vcan1"]
    scene_class = got.pop("scene_class")

    motion = recorded_motion(tmp_path / "balance.mcap")  # the plant's poses, from the trace
    recorded = dict(zip((motion.t_s * 1e9).round().astype(np.int64).tolist(), motion.qpos))
    matched = 0
    for t_ns, payload in got["/scene"]:
        update = scene_class.FromString(payload)
        assert {e.id for e in update.entities} == {"world", "robot", "contacts"}
        if t_ns in recorded:
            position, quaternion = body_box(update)
            assert np.allclose(position, recorded[t_ns][:3], atol=1e-9)
            assert abs(np.dot(quaternion, recorded[t_ns][3:7])) == pytest.approx(1.0, abs=1e-9)
            matched += 1
    assert matched > 20
    arrows = [len(next(e for e in scene_class.FromString(p).entities if e.id == "contacts").arrows)
              for _, p in got["/scene"][-5:]]
    assert min(arrows) >= 2  # both wheels on the ground: at least one contact force each

    reader = TraceReader(tmp_path / "balance.mcap")
    state = reader.sim_state()
    times = {round(t * 1e9): i for i, t in enumerate(state["t"])}
    for t_ns, payload in got["/sim/state"][::50]:
        row = json.loads(payload)
        assert row["pitch"] == state["pitch"][times[t_ns]] and row["x"] == state["x"][times[t_ns]]
    # the trace's frames, in its own layout (a trace's window may be cut in two where a chunk closes)
    live = [(f.t_ns, f.arbitration_id, f.data) for t_ns, payload in got["/can/vcan1"]
            for f in can_batch.unpack(payload, t_ns, "vcan1")]
    traced = [(f.t_ns, f.arbitration_id, f.data) for f in reader.frames("vcan1") if f.t_ns >= live[0][0]]
    assert live == traced and len(live) > 10_000


def test_a_port_in_use_is_a_one_line_usage_error(tmp_path):
    import socket

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        done = subprocess.run([sys.executable, "-m", "wheelleg.hil.cli", "run", "balance", "--live", "--port",
                               str(port), "--out", str(tmp_path), "--no-plot", "-q"],
                              capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and f"cannot listen on 127.0.0.1:{port}" in done.stderr
    assert done.stderr.count("\n") == 1


def test_scene_goes_into_the_trace_with_scene_and_only_then(tmp_path):
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

    from wheelleg.hil import cli

    for flag, out in (["--scene"], tmp_path / "with"), ([], tmp_path / "without"):
        assert cli.main(["run", "jump", "--duration", "1.0", *flag, "--out", str(out), "--no-plot", "-q"]) in (0, 1)
    assert "/scene" not in TraceReader(tmp_path / "without" / "jump.mcap").topics
    reader = TraceReader(tmp_path / "with" / "jump.mcap")
    schema, encoding, _ = reader.schema("/scene")
    assert encoding == "protobuf" and schema.name == "foxglove.SceneUpdate"
    pool = descriptor_pool.DescriptorPool()
    for file in descriptor_pb2.FileDescriptorSet.FromString(schema.data).file:
        pool.Add(file)
    scene_class = message_factory.GetMessageClass(pool.FindMessageTypeByName(schema.name))
    motion = recorded_motion(tmp_path / "with" / "jump.mcap")
    recorded = dict(zip((motion.t_s * 1e9).round().astype(np.int64).tolist(), motion.qpos))
    scenes = reader.records("/scene")
    assert len(scenes) == pytest.approx(1.0 / 0.02, abs=2)
    common = [(t, p) for t, p in scenes if t in recorded]
    assert len(common) > 20
    for t_ns, payload in common:
        position, _ = body_box(scene_class.FromString(payload))
        assert np.allclose(position, recorded[t_ns][:3], atol=1e-9)


def test_the_shipped_layout_is_the_built_one_and_plots_fields_the_run_streams(capsys):
    from wheelleg.controller.telemetry import DEBUG_FIELDS
    from wheelleg.hil import cli
    from wheelleg.hil.record.schemas import SIM_STATE_FIELDS
    from wheelleg.hil.watch import layout

    assert cli.main(["layout"]) == 0
    path = capsys.readouterr().out.strip()
    text = open(path).read()
    assert text.strip() == layout.build()
    shown = json.loads(text)
    paths = [series["value"] for panel in walk(shown["content"]) if panel.get("panelType") == "Plot"
             for series in panel["config"]["paths"]]
    fields = {"/sim/state": SIM_STATE_FIELDS, "/controller/debug": DEBUG_FIELDS}
    assert paths and all(p.partition(".")[2] in fields[p.partition(".")[0]] for p in paths), paths
    kinds = {panel.get("panelType") for panel in walk(shown["content"])}
    assert {"ThreeDee", "Plot", "RawMessages"} <= kinds and "/scene" in text and "/scenario/events" in text


def walk(node: dict):
    """Every panel of a layout's content tree."""
    if node.get("type") == "panel":
        yield node
    for item in node.get("items", []):
        yield from walk(item["content"])


@pytest.mark.parametrize("argv, message", [
    (["--view-fast"], "--view-fast goes with --view"),
    (["--live", "--realtime"], "drop --realtime"),
    (["--scene", "--realtime"], "drop --realtime"),
    (["--live", "--port", "70000"], "--port 70000: must be 0..65535"),
    (["--live-wait", "5"], "--live-wait goes with --live"),
])
def test_watching_options_that_do_not_go_together_are_one_line_usage_errors(tmp_path, capsys, argv, message):
    from wheelleg.hil import cli

    assert cli.main(["run", "balance", *argv, "--out", str(tmp_path), "-q"]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not (tmp_path / "balance.mcap").exists()
