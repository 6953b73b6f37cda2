"""Benchmark (not a test): what watching a run costs, and the Foxglove SDK's MCAP writer against the rig's.

    python -m tools.watch_cost [SCENARIO] [--duration S] [--repeats N]

Printed, all from one process (the machine is shared: compare the ratios):

1. the run's CPU time without and with ``--live`` (a WebSocket client subscribed to every
   channel, in a process of its own as the Foxglove app is; the server's threads count), best
   of ``--repeats`` each, interleaved, and the ratio;
2. the /scene topic's size per simulated second (protobuf SceneUpdate at the live rate),
   raw and zstd-compressed, against the trace's own size per simulated second;
3. the same records (every message of the trace just made) written by the rig's
   hand-written chunk writer (``hil/record/mcap_chunks.py``) and by the Foxglove SDK's
   MCAP writer (``foxglove.open_mcap``, zstd, chunks of the same size): CPU time of each.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

from tools import known_scenario
from wheelleg.hil import scenarios
from wheelleg.hil.run.rig import Rig, RigConfig


def timed_run(scenario, out: Path, live: bool) -> float:
    """CPU s of this process over one lockstep run (with the live server and a subscribed client when ``live``).
    CPU, not wall: the machine is shared."""
    rig = Rig(scenario, RigConfig(trace_flush_s=None), out)
    watchers, client = [], None
    if live:
        from wheelleg.hil.watch.live import LiveServer

        server = LiveServer(rig, "127.0.0.1", 0)
        watchers = [server]
        rig.watchers.append(server)
        client = subprocess.Popen([sys.executable, "-m", "tools.watch_cost", "--client", server.url],
                                  stdout=subprocess.PIPE, text=True)
        assert client.stdout.readline().startswith("subscribed")  # before the run starts
    cpu0 = time.process_time()
    rig.run()
    cpu = time.process_time() - cpu0
    for watcher in watchers:
        watcher.close()
    if client is not None:
        print(f"  (the client, another process, {client.communicate(timeout=60)[0].strip()})")
    return cpu


def subscriber(url: str) -> None:
    """A Foxglove WebSocket client subscribed to every channel (``--client URL``): says "subscribed", then
    counts what it gets until the server stops."""
    import json

    from websockets.sync.client import connect

    messages = 0
    with connect(url, subprotocols=["foxglove.sdk.v1"], max_size=None) as ws:
        channels = {}
        deadline = time.monotonic() + 10
        while len(channels) < 6 and time.monotonic() < deadline:
            message = ws.recv(timeout=10)
            if isinstance(message, str) and json.loads(message).get("op") == "advertise":
                channels.update({c["topic"]: c["id"] for c in json.loads(message)["channels"]})
        ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": i, "channelId": c} for i, c in enumerate(channels.values(), start=1)]}))
        print("subscribed", flush=True)
        try:
            while True:
                if not isinstance(ws.recv(timeout=30), str):
                    messages += 1
        except Exception:  # noqa: BLE001 - the server stopped
            pass
    print(f"received {messages} messages on {len(channels)} channels")


def scene_size(trace: Path, duration_s: float) -> tuple[float, float]:
    """(raw, zstd) bytes per simulated second of /scene at the live rate, drawn from the trace's poses."""
    import mujoco
    import zstandard

    from wheelleg.hil.watch.foxglove_scene import SceneBuilder
    from wheelleg.hil.watch.live import SCENE_PERIOD_S
    from wheelleg.hil.watch.scene import recorded_motion

    motion = recorded_motion(trace)
    builder, data = SceneBuilder(motion.model), mujoco.MjData(motion.model)
    payloads = []
    for k in range(round(duration_s / SCENE_PERIOD_S)):
        data.qpos[:] = motion.qpos[motion.index_at(k * SCENE_PERIOD_S)]
        mujoco.mj_forward(motion.model, data)
        payloads.append(builder.update(data, round(k * SCENE_PERIOD_S * 1e9)).encode())
    raw = b"".join(payloads)
    packed = zstandard.ZstdCompressor(level=1).compress(raw)
    return len(raw) / duration_s, len(packed) / duration_s


def writers(trace: Path) -> tuple[float, float, int, int]:
    """CPU s and bytes of the trace's messages written by the rig's writer and by the SDK's."""
    import foxglove
    from mcap.reader import make_reader

    from wheelleg.hil.record.mcap_chunks import ChunkedMcapWriter

    with open(trace, "rb") as f:
        reader = make_reader(f)
        records = [(channel.topic, schema, channel.message_encoding, message.log_time, message.data)
                   for schema, channel, message in reader.iter_messages(log_time_order=False)]
    out = Path(tempfile.mkdtemp())
    cpu0 = time.process_time()
    with open(out / "rig.mcap", "wb") as f:
        writer = ChunkedMcapWriter(f, flush_interval_s=None)
        writer.start()
        ids = {}
        for topic, schema, encoding, t_ns, data in records:
            if topic not in ids:
                schema_id = writer.register_schema(schema.name, schema.encoding, schema.data) if schema else 0
                ids[topic] = writer.register_channel(topic, encoding, schema_id)
            writer.add_message(ids[topic], t_ns, data)
        writer.finish()
    rig_cpu = time.process_time() - cpu0
    cpu0 = time.process_time()
    context = foxglove.Context()
    options = foxglove.mcap.MCAPWriteOptions(compression=foxglove.mcap.MCAPCompression.Zstd, chunk_size=512 * 1024)
    sdk = foxglove.open_mcap(out / "sdk.mcap", context=context, writer_options=options)
    channels = {}
    for topic, schema, encoding, t_ns, data in records:
        channel = channels.get(topic)
        if channel is None:
            fox_schema = foxglove.Schema(name=schema.name, encoding=schema.encoding, data=schema.data) if schema else None
            channel = channels[topic] = foxglove.Channel(topic, message_encoding=encoding, schema=fox_schema,
                                                         context=context)
        channel.log(data, log_time=t_ns)
    sdk.close()
    sdk_cpu = time.process_time() - cpu0
    return rig_cpu, sdk_cpu, (out / "rig.mcap").stat().st_size, (out / "sdk.mcap").stat().st_size


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario", nargs="?", default="balance", type=known_scenario)
    parser.add_argument("--duration", type=float, default=None)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--client", metavar="URL", help=argparse.SUPPRESS)  # the subscriber process
    args = parser.parse_args(argv)
    if args.client:
        subscriber(args.client)
        return 0
    scenario = scenarios.get(args.scenario)
    if args.duration is not None:
        scenario = replace(scenario, duration_s=args.duration)
    out = Path(tempfile.mkdtemp())
    walls = {False: [], True: []}
    for _ in range(args.repeats):
        for live in (False, True):
            walls[live].append(timed_run(scenario, out / ("live" if live else "off"), live))
    off, on = min(walls[False]), min(walls[True])
    print(f"{scenario.name} {scenario.duration_s:g} s: CPU without --live {off:.2f} s, with --live and a subscribed "
          f"client {on:.2f} s (best of {args.repeats}): --live costs {on / off - 1:+.1%} of the run's time")
    trace = out / "off" / f"{scenario.name}.mcap"
    raw, packed = scene_size(trace, scenario.duration_s)
    per_s = trace.stat().st_size / scenario.duration_s
    print(f"/scene at the live rate: {raw / 1e3:.1f} kB raw, {packed / 1e3:.1f} kB zstd per simulated s; "
          f"the trace: {per_s / 1e3:.1f} kB per simulated s ({packed / per_s:.0%} more with /scene)")
    rig_cpu, sdk_cpu, rig_bytes, sdk_bytes = writers(trace)
    print(f"the trace's messages written again: rig's chunk writer {rig_cpu * 1e3:.0f} ms CPU ({rig_bytes / 1e6:.2f} MB), "
          f"Foxglove SDK's MCAP writer {sdk_cpu * 1e3:.0f} ms CPU ({sdk_bytes / 1e6:.2f} MB): "
          f"SDK/rig {sdk_cpu / rig_cpu:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
