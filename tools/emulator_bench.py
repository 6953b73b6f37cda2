"""Micro-benchmark of the emulators' hot paths (not a test: timings here are noisy).

``python -m tools.emulator_bench`` prints microseconds per CyberGear motion
request handled + reply built, per C620 feedback frame and per IMU period
(3 frames), device only (no bus, best of 5 runs), then the same through a DeviceNode on a
python-can virtual bus (send, service, receive).
"""
from __future__ import annotations

import time

import can

from wheelleg.dbc import cybergear as cg
from wheelleg.dbc import load_file, truncating_raw
from wheelleg.emulators.c620 import C620
from wheelleg.emulators.cybergear import CyberGear
from wheelleg.emulators.imu import Imu
from wheelleg.emulators.node import DeviceNode

N = 20000


def _motion_request(motor_id: int) -> can.Message:
    msg = load_file("cybergear.dbc").get_message_by_name("CG_MotionCmd")
    raw = {s.name: truncating_raw(s, v) for s, v in zip(msg.signals, (0.5, 0.0, 30.0, 1.0))}
    return can.Message(arbitration_id=cg.motion_id(1.0, motor_id), data=msg.encode(raw, scaling=False),
                       is_extended_id=True)


def _per_call_us(fn, n: int = N, repeats: int = 5) -> float:
    """Best of ``repeats`` runs of ``n // repeats`` calls (the least disturbed by other load)."""
    per_run = max(1, n // repeats)
    best = float("inf")
    for r in range(repeats):
        start = time.perf_counter()
        for i in range(r * per_run, (r + 1) * per_run):
            fn(i)
        best = min(best, (time.perf_counter() - start) / per_run)
    return best * 1e6


def bench_devices() -> dict[str, float]:
    motor = CyberGear(motor_id=1)
    motor.handle(can.Message(arbitration_id=cg.request_id(cg.T_ENABLE, 0xFD, 1), data=bytes(8),
                             is_extended_id=True), 0.0)
    request = _motion_request(1)
    esc = C620(esc_id=1)
    imu = Imu()
    return {
        "cybergear motion request + type-2 reply": _per_call_us(lambda i: motor.handle(request, i * 1e-3)),
        "c620 feedback frame": _per_call_us(lambda i: esc.periodic(i * 1e-3)),
        "imu period (3 frames)": _per_call_us(lambda i: imu.periodic(i * 2e-3)),
    }


def bench_bus() -> dict[str, float]:
    host = can.Bus(interface="virtual", channel="emulators-bench", receive_own_messages=False)
    device_bus = can.Bus(interface="virtual", channel="emulators-bench")
    try:
        motor = CyberGear(motor_id=1)
        node = DeviceNode(device_bus, [motor])
        host.send(can.Message(arbitration_id=cg.request_id(cg.T_ENABLE, 0xFD, 1), data=bytes(8),
                              is_extended_id=True))
        node.service(0.0)
        host.recv(timeout=0)
        request = _motion_request(1)

        def round_trip(i: int) -> None:
            host.send(request)
            node.service(i * 1e-3)
            host.recv(timeout=0)

        return {"cybergear request/reply over a virtual bus": _per_call_us(round_trip, N // 4)}
    finally:
        host.shutdown()
        device_bus.shutdown()


def main() -> None:
    for name, us in {**bench_devices(), **bench_bus()}.items():
        print(f"{us:8.1f} us  {name}")


if __name__ == "__main__":
    main()
