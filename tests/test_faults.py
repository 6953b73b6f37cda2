"""Each fault injector of hil/run/faults.py on its own, without the physics (fast)."""
from __future__ import annotations

from types import SimpleNamespace

import can
import numpy as np
import pytest

from wheelleg.controller import constants as C
from wheelleg.dbc import cybergear as cg
from wheelleg.dbc import load_bus
from wheelleg.emulators.c620 import C620
from wheelleg.emulators.cybergear import CyberGear
from wheelleg.emulators.imu import Imu, ImuNoise
from wheelleg.emulators.remote import Remote
from wheelleg.hil.run import faults
from wheelleg.hil.bus.busload import frame_bits
from wheelleg.hil.bus.frame_faults import BusFaults
from wheelleg.hil.bus.plant_bus import SimClock

DB1 = load_bus("can1")
SYNC = DB1.get_message_by_name("SYNC")
HEARTBEAT = DB1.get_message_by_name("Heartbeat")


def fake_rig(seed: int = 0):
    """Real emulated devices and stub bus ends: enough for every injector's Action."""
    devices = {j.name: CyberGear(motor_id=j.motor_id) for j in C.JOINTS}
    devices.update({w.name: C620(esc_id=w.esc_id) for w in C.WHEELS})
    devices["imu"] = Imu(noise=ImuNoise.none(), rng=np.random.default_rng(1))
    devices["remote"] = Remote()
    plant = SimpleNamespace(devices=devices, imu=devices["imu"])
    clock = SimClock()
    return SimpleNamespace(plant=plant, clock=clock, bus_faults={"can1": BusFaults(clock), "can2": BusFaults(clock)},
                           config=SimpleNamespace(seed=seed))


def apply(rig, actions, kind="start"):
    """Run the start (or end) Action of a fault; returns its event dict."""
    action = actions[0] if kind == "start" else actions[1]
    return action.fn(rig)


def std(frame_id: int, t_s: float = 0.0, data: bytes = bytes(8)) -> can.Message:
    return can.Message(arbitration_id=frame_id, data=data, is_extended_id=False, timestamp=t_s, check=False)


def sync(t_s: float = 0.0) -> can.Message:
    return std(SYNC.frame_id, t_s, SYNC.encode({"Tick": 1}))


def send(rig, bus: str, msg: can.Message, t_s: float) -> list:
    rig.clock.set_s(t_s)
    return rig.bus_faults[bus].outbound([msg])


# -- device faults --------------------------------------------------------------------------
def test_silent_device_sends_nothing_until_the_fault_ends():
    rig = fake_rig()
    acts = faults.silent("imu", 1.0, 0.5)
    event = apply(rig, acts)
    assert event == {"device": "imu", "t_s": 1.0, "duration_s": 0.5}
    assert acts[0].kind == "fault_silent" and acts[1].kind == "fault_end" and acts[1].t_s == 1.5
    imu = rig.plant.imu
    assert imu.periodic(0.002) == []
    apply(rig, acts, "end")
    assert len(imu.periodic(0.004)) == 3


def test_silent_joint_still_obeys_but_never_answers():
    rig = fake_rig()
    apply(rig, faults.silent("left_front_hip", 0.0))
    motor = rig.plant.devices["left_front_hip"]
    enable = can.Message(arbitration_id=cg.request_id(cg.T_ENABLE, C.CG_HOST_ID, 1), data=bytes(8),
                         is_extended_id=True)
    assert motor.handle(enable, 0.0) == [] and motor.mode == 2  # enabled, silently


def test_frozen_wheel_repeats_its_last_feedback_while_the_shaft_turns():
    rig = fake_rig()
    esc = rig.plant.devices["left_wheel"]
    first = esc.periodic(0.001)[0]
    apply(rig, faults.frozen("left_wheel", 0.0))
    esc.shaft.angle, esc.shaft.speed = 1.0, 5.0
    again = esc.periodic(0.002)[0]
    assert bytes(again.data) == bytes(first.data) and again.arbitration_id == first.arbitration_id
    assert again.timestamp == pytest.approx(0.002)
    esc.frozen = False
    assert bytes(esc.periodic(0.003)[0].data) != bytes(first.data)


def test_frozen_cybergear_repeats_per_communication_type():
    motor = CyberGear(motor_id=1)
    poll = can.Message(arbitration_id=cg.request_id(cg.T_FEEDBACK, C.CG_HOST_ID, 1), data=bytes(8),
                       is_extended_id=True)
    first = motor.handle(poll, 0.0)[0]
    motor.frozen = True
    motor.shaft.angle = 2.0
    assert bytes(motor.handle(poll, 0.002)[0].data) == bytes(first.data)


def test_esc_hold_keeps_the_last_current_whatever_is_commanded():
    rig = fake_rig()
    esc = rig.plant.devices["left_wheel"]
    cmd = DB1.get_message_by_name("C620_Cmd_1_4")
    esc.handle(std(cmd.frame_id, data=cmd.encode({"ESC1_Current": 5.0, "ESC2_Current": 0, "ESC3_Current": 0,
                                                   "ESC4_Current": 0})), 0.0)
    event = apply(rig, faults.esc_hold("left_wheel", 0.1))
    assert event["device"] == "left_wheel"
    esc.handle(std(cmd.frame_id, data=bytes(8)), 0.2)  # zero current asked: ignored
    assert esc.commanded_current(0.2) == pytest.approx(5.0, abs=0.01)
    assert esc.periodic(0.2)  # feedback goes on
    with pytest.raises(ValueError):
        faults.esc_hold("imu", 0.0)


def test_cybergear_fault_bit_is_latched_and_in_every_reply_id():
    rig = fake_rig()
    event = apply(rig, faults.cybergear_fault("right_rear_hip", "FaultUnderVoltage", 0.5))
    assert event == {"device": "right_rear_hip", "fault": "FaultUnderVoltage", "t_s": 0.5, "duration_s": None}
    motor = rig.plant.devices["right_rear_hip"]
    poll = can.Message(arbitration_id=cg.request_id(cg.T_FEEDBACK, C.CG_HOST_ID, 4), data=bytes(8),
                       is_extended_id=True)
    reply = motor.handle(poll, 0.0)[0]
    assert cg.parse_reply_id(reply.arbitration_id).faults == {"FaultUnderVoltage"}
    with pytest.raises(ValueError):
        faults.cybergear_fault("right_rear_hip", "FaultCoffee", 0.0)


def test_imu_bias_shifts_the_rate_and_ends():
    rig = fake_rig()
    imu = rig.plant.imu
    acts = faults.imu_bias(0.0, 1.0, gyro_bias_rad_s=(0.0, 0.3, 0.0), accel_bias_m_s2=(0.5, 0.0, 0.0))
    apply(rig, acts)
    _, gyro, accel = imu.measure()
    assert gyro == pytest.approx((0.0, 0.3, 0.0)) and accel[0] == pytest.approx(0.5)
    apply(rig, acts, "end")
    assert imu.measure()[1] == pytest.approx((0.0, 0.0, 0.0))


def test_imu_noise_sets_the_spread():
    rig = fake_rig()
    apply(rig, faults.imu_noise(0.0, None, gyro_std_rad_s=0.1, accel_std_m_s2=0.0, attitude_std_rad=0.0))
    rates = np.array([rig.plant.imu.measure()[1] for _ in range(2000)])
    assert np.std(rates, axis=0) == pytest.approx([0.1] * 3, rel=0.1)


def test_imu_spikes_hit_one_axis_by_the_magnitude():
    rig = fake_rig()
    apply(rig, faults.imu_spikes(0.0, None, probability=1.0, magnitude_rad_s=20.0))
    for _ in range(20):
        gyro = np.abs(rig.plant.imu.measure()[1])
        assert sorted(gyro) == pytest.approx([0.0, 0.0, 20.0])
    with pytest.raises(ValueError):
        faults.imu_spikes(0.0, None, probability=1.5, magnitude_rad_s=1.0)


def test_bad_arguments_are_clear_errors_when_the_scenario_is_defined():
    with pytest.raises(ValueError, match="no device 'left_knee'"):
        faults.silent("left_knee", 0.0)
    with pytest.raises(ValueError, match="no device 'imu'"):
        faults.cybergear_fault("imu", "FaultOverTemp", 0.0)
    with pytest.raises(ValueError, match="duration"):
        faults.silent("imu", 0.0, 0.0)
    with pytest.raises(ValueError, match="bus must be"):
        faults.frame_loss("can3", 0.0, None, 0.1)
    with pytest.raises(ValueError, match="direction"):
        faults.frame_loss("can1", 0.0, None, 0.1, direction="sideways")
    with pytest.raises(ValueError, match="babble load"):
        faults.babble("can2", 0.0, None, 0.0)


# -- frame faults ---------------------------------------------------------------------------
def test_frame_loss_drops_about_its_rate_and_never_the_lockstep_frames():
    rig = fake_rig()
    acts = faults.frame_loss("can1", 0.0, 1.0, 0.3)
    apply(rig, acts)
    passed = sum(len(send(rig, "can1", std(0x201, k * 1e-3), k * 1e-3)) for k in range(4000))
    assert passed / 4000 == pytest.approx(0.7, abs=0.03)
    assert all(send(rig, "can1", sync(), 0.0) for _ in range(200))
    end = apply(rig, acts, "end")
    assert end["fault"] == "frame_loss" and end["frames_affected"] == 4000 - passed
    assert len(send(rig, "can1", std(0x201), 2.0)) == 1


def test_frame_loss_is_the_same_for_the_same_seed_and_differs_for_another():
    def pattern(seed):
        rig = fake_rig(seed)
        apply(rig, faults.frame_loss("can2", 0.0, None, 0.5, motors=[1]))
        reply = can.Message(arbitration_id=cg.reply_id(cg.T_FEEDBACK, 1, C.CG_HOST_ID), data=bytes(8),
                            is_extended_id=True)
        return [len(send(rig, "can2", reply, k * 1e-3)) for k in range(200)]

    assert pattern(1) == pattern(1) and pattern(1) != pattern(2)


def test_frame_loss_per_id_spares_other_frames():
    rig = fake_rig()
    apply(rig, faults.frame_loss("can1", 0.0, None, 1.0, ids=[0x201]))
    assert send(rig, "can1", std(0x201), 0.0) == []
    assert len(send(rig, "can1", std(0x202), 0.0)) == 1


def test_frame_loss_towards_the_devices_swallows_controller_frames():
    rig = fake_rig()
    apply(rig, faults.frame_loss("can1", 0.0, None, 1.0, direction=faults.TO_DEVICES))
    layer = rig.bus_faults["can1"]
    assert layer.inbound(std(0x200)) is False
    hb = std(HEARTBEAT.frame_id)
    assert layer.inbound(hb) is True  # the rig still sees the heartbeat
    assert len(send(rig, "can1", std(0x201), 0.0)) == 1  # the other way is untouched


def test_delayed_frames_arrive_late_and_in_order():
    rig = fake_rig()
    apply(rig, faults.frame_delay("can1", 0.0, None, 0.003, jitter_s=0.002))
    assert send(rig, "can1", std(0x201, 0.0), 0.0) == []
    assert send(rig, "can1", std(0x202, 0.001), 0.001) == []
    released = send(rig, "can1", sync(0.006), 0.006)
    assert [m.arbitration_id for m in released] == [0x201, 0x202, SYNC.frame_id]
    assert 0.003 <= released[0].timestamp <= 0.005 and released[1].timestamp >= released[0].timestamp


def test_a_delayed_frame_is_released_by_a_later_frame_and_not_delayed_again():
    rig = fake_rig()
    apply(rig, faults.frame_delay("can1", 0.0, None, 0.002))
    assert send(rig, "can1", std(0x201, 0.0), 0.0) == []
    out = send(rig, "can1", std(0x202, 0.003), 0.003)  # held in turn; the first one is due
    assert [m.arbitration_id for m in out] == [0x201]
    assert [m.arbitration_id for m in send(rig, "can1", std(0x201, 0.005), 0.005)] == [0x202]


def test_corruption_flips_one_bit_or_truncates():
    rig = fake_rig()
    apply(rig, faults.frame_corruption("can1", 0.0, None, 1.0))
    out = send(rig, "can1", std(0x201, data=bytes(8)), 0.0)[0]
    assert sum(bin(b).count("1") for b in out.data) == 1 and out.dlc == 8
    rig2 = fake_rig()
    apply(rig2, faults.frame_corruption("can1", 0.0, None, 1.0, how="truncate"))
    assert send(rig2, "can1", std(0x201), 0.0)[0].dlc == 7
    with pytest.raises(ValueError):
        faults.frame_corruption("can1", 0.0, None, 2.0)


def test_error_frames_follow_frames():
    rig = fake_rig()
    apply(rig, faults.error_frames("can1", 0.0, None, 1.0))
    out = send(rig, "can1", std(0x201), 0.0)
    assert [m.is_error_frame for m in out] == [False, True]


def test_bus_off_stops_everything_but_the_lockstep_both_ways():
    rig = fake_rig()
    acts = faults.bus_off("can2", 1.0, 0.1)
    assert apply(rig, acts)["bus"] == "can2"
    layer = rig.bus_faults["can2"]
    assert send(rig, "can2", std(0x201), 1.0) == []
    assert layer.inbound(can.Message(arbitration_id=0x0100_0001, is_extended_id=True)) is False
    assert len(send(rig, "can2", sync(), 1.0)) == 1
    apply(rig, acts, "end")
    assert len(send(rig, "can2", std(0x201), 1.2)) == 1
    with pytest.raises(ValueError):
        faults.bus_off("can3", 1.0, 0.1)


def test_babble_offers_its_share_of_the_bus():
    rig = fake_rig()
    apply(rig, faults.babble("can2", 0.0, None, 0.5))
    out = [m for k in range(101) for m in send(rig, "can2", sync(k * 1e-3), k * 1e-3)]
    babble = [m for m in out if m.arbitration_id == 0x001]
    wire = len(babble) * frame_bits(0x001, False, bytes(8)) / 1e6  # s at 1 Mbit/s
    assert wire / 0.1 == pytest.approx(0.5, abs=0.02)


def test_arbitration_sends_in_priority_order_and_drops_what_waits_too_long():
    rig = fake_rig()
    apply(rig, faults.arbitration("can1", 0.0, None, max_wait_s=0.001))
    layer = rig.bus_faults["can1"]
    layer.inbound(std(0x200))  # the controller's frame holds the wire first
    assert send(rig, "can1", std(0x300, 0.0), 0.0) == []
    assert send(rig, "can1", std(0x100, 0.0), 0.0) == []
    out = send(rig, "can1", sync(0.0005), 0.0005)
    assert [m.arbitration_id for m in out] == [0x100, 0x300, SYNC.frame_id]  # 0x100 wins
    # a bus flooded by a higher-priority node: 0x300 never wins and is aborted after 1 ms
    apply(rig, faults.babble("can1", 0.0, None, 1.2))
    got = [m.arbitration_id for k in range(1, 40) for m in send(rig, "can1", std(0x300, k * 1e-4), k * 1e-4)]
    assert 0x300 not in got and layer.arbiter.count > 0


def test_priority_follows_can_arbitration():
    ext = can.Message(arbitration_id=0x0200_0100, is_extended_id=True)  # base id 0x080
    assert faults.priority(std(0x080)) < faults.priority(ext) < faults.priority(std(0x081))
