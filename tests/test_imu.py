"""IMU emulator: rig.dbc's three frames every period, truth plus seeded noise and bias."""
from __future__ import annotations

import math
import threading
import uuid

import can
import numpy as np
import pytest

from wheelleg.dbc import load_bus
from wheelleg.emulators.imu import Imu, ImuNoise
from wheelleg.emulators.node import DeviceNode
from wheelleg.hil.cli import build_parser
from wheelleg.hil.commands import emulate

DB = load_bus("can1")
ORIENT, GYRO, ACCEL = (DB.get_message_by_name(n) for n in ("IMU_Orientation", "IMU_Gyro", "IMU_Accel"))


def sample(imu: Imu, now_s: float) -> dict:
    """The three frames due at ``now_s``, decoded and merged."""
    frames = imu.periodic(now_s)
    assert [m.arbitration_id for m in frames] == [ORIENT.frame_id, GYRO.frame_id, ACCEL.frame_id]
    out = {}
    for m in frames:
        out.update(DB.decode_message(m.arbitration_id, m.data))
    return out


def test_three_frames_every_period_over_the_bus(vbus_pair):
    host, device_bus = vbus_pair
    node = DeviceNode(device_bus, [Imu(period_s=0.002, noise=ImuNoise.none())])
    got = []
    for k in range(10):  # served every 1 ms for 10 ms
        node.service(k * 0.001)
        while (m := host.recv(timeout=0)) is not None:
            got.append(m)
    assert [m.arbitration_id for m in got] == [ORIENT.frame_id, GYRO.frame_id, ACCEL.frame_id] * 5
    assert [m.dlc for m in got[:3]] == [ORIENT.length, GYRO.length, ACCEL.length]
    assert not any(m.is_extended_id for m in got)


def test_noiseless_frames_carry_the_truth_within_one_step():
    imu = Imu(noise=ImuNoise.none())
    half = math.sqrt(0.5)
    imu.set_truth((half, 0.0, half, 0.0), (0.1, -2.0, 3.3), (1.0, -0.5, 9.81))
    s = sample(imu, 0.0)
    frames = imu.periodic(0.002)
    assert all(m.timestamp == 0.002 and not m.is_rx for m in frames)
    expected = {"QuatW": half, "QuatX": 0.0, "QuatY": half, "QuatZ": 0.0, "RateX": 0.1, "RateY": -2.0,
                "RateZ": 3.3, "AccX": 1.0, "AccY": -0.5, "AccZ": 9.81}
    for name, value in expected.items():
        step = DB.get_message_by_name(
            "IMU_Orientation" if name.startswith("Quat") else "IMU_Gyro" if name.startswith("Rate")
            else "IMU_Accel").get_signal_by_name(name).scale
        assert s[name] == pytest.approx(value, abs=step / 2 + 1e-12), name


def test_values_beyond_a_field_saturate():
    imu = Imu(noise=ImuNoise.none())
    imu.set_truth((1.0, 0.0, 0.0, 0.0), (100.0, -100.0, 0.0), (0.0, 0.0, 500.0))
    s = sample(imu, 0.0)
    assert s["QuatW"] == pytest.approx(1.0, abs=1e-4)  # +1 is one step past the int16: clamped
    assert s["RateX"] == pytest.approx(32.767) and s["RateY"] == pytest.approx(-32.768)
    assert s["AccZ"] == pytest.approx(163.835)


def test_same_seed_same_bytes_other_seed_other_bytes():
    def stream(seed: int) -> list[bytes]:
        imu = Imu(rng=np.random.default_rng(seed))
        return [bytes(m.data) for k in range(50) for m in imu.periodic(k * 0.002)]

    assert stream(7) == stream(7)
    assert stream(7) != stream(8)


def test_noise_and_bias_statistics():
    noise = ImuNoise(gyro_std_rad_s=0.05, gyro_bias_rad_s=(0.02, 0.0, -0.03), accel_std_m_s2=0.2,
                     accel_bias_m_s2=(0.0, 0.5, 0.0), attitude_std_rad=0.01)
    imu = Imu(noise=noise, rng=np.random.default_rng(3))
    samples = [sample(imu, k * 0.002) for k in range(2000)]
    rate_x = np.array([s["RateX"] for s in samples])
    acc_y = np.array([s["AccY"] for s in samples])
    rate_z = np.array([s["RateZ"] for s in samples])
    assert rate_x.mean() == pytest.approx(0.02, abs=0.005) and rate_x.std() == pytest.approx(0.05, rel=0.1)
    assert rate_z.mean() == pytest.approx(-0.03, abs=0.005)
    assert acc_y.mean() == pytest.approx(0.5, abs=0.03) and acc_y.std() == pytest.approx(0.2, rel=0.1)
    quats = np.array([[s["QuatW"], s["QuatX"], s["QuatY"], s["QuatZ"]] for s in samples])
    assert np.linalg.norm(quats, axis=1) == pytest.approx(1.0, abs=1e-4)  # still unit quaternions
    tilt = 2 * np.arcsin(np.linalg.norm(quats[:, 1:], axis=1))  # rad off the (identity) truth
    assert np.sqrt((tilt ** 2).mean() / 3) == pytest.approx(0.01, rel=0.15)


def test_imu_ignores_every_frame_and_bad_truth_is_a_clear_error():
    imu = Imu()
    for msg in (can.Message(arbitration_id=0x100, data=bytes(8), is_extended_id=False),
                can.Message(arbitration_id=0x1FFFFFFF, data=b"", is_extended_id=True)):
        assert imu.handle(msg, 0.0) == []
    with pytest.raises(ValueError, match="quaternion"):
        imu.set_truth((1.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 9.81))
    with pytest.raises(ValueError, match="period"):
        Imu(period_s=0.0)


def test_wheelleg_emulate_imu_streams_its_frames():
    channel = f"emulate-imu-{uuid.uuid4().hex}"
    args = build_parser().parse_args(["emulate", "imu", "-i", "virtual", "-c", channel])
    stop, result = threading.Event(), {}
    thread = threading.Thread(target=lambda: result.update(rc=emulate.run(args, stop)))
    host = can.Bus(interface="virtual", channel=channel)
    thread.start()
    try:
        got = [host.recv(timeout=20.0) for _ in range(6)]  # generous: bounds a hang only
    finally:
        stop.set()
        thread.join(timeout=20.0)
        host.shutdown()
    assert {m.arbitration_id for m in got if m is not None} == {ORIENT.frame_id, GYRO.frame_id, ACCEL.frame_id}
    assert DB.decode_message(ACCEL.frame_id, next(m for m in got if m.arbitration_id == ACCEL.frame_id).data)[
        "AccZ"] == pytest.approx(9.81, abs=0.2)
    assert not thread.is_alive() and result["rc"] == 0
