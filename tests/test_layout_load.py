"""tools/layout_load.py: scaling the robot's frame layout to other control rates."""
import pytest

from wheelleg.dbc import cybergear as cg
from tools.layout_load import follows_the_loop, frame_kind, load_at


def test_loop_frames_scale_with_the_control_rate_device_clocks_do_not():
    kinds = {"cmd": (500.0, 140.0, True), "imu": (500.0, 100.0, False)}
    assert load_at(kinds, 500.0, 500.0) == pytest.approx((500 * 140 + 500 * 100) / 1e6)
    assert load_at(kinds, 500.0, 1000.0) == pytest.approx((1000 * 140 + 500 * 100) / 1e6)


def test_which_frames_follow_the_loop():
    assert follows_the_loop(cg.motion_id(1.0, 3), True)  # CyberGear commands and replies
    assert follows_the_loop(0x200, False) and follows_the_loop(0x080, False) and follows_the_loop(0x710, False)
    assert not follows_the_loop(0x201, False) and not follows_the_loop(0x100, False)  # C620, IMU: own clocks


def test_frame_kinds_name_the_cybergear_type_and_motor():
    assert frame_kind(cg.reply_id(cg.T_FEEDBACK, 4, 0xFD, 2), True) == "cybergear type 2 motor 4"
    assert frame_kind(cg.motion_id(-2.0, 1), True) == "cybergear type 1 motor 1"
    assert frame_kind(0x201, False) == "0x201"


def test_an_unreadable_trace_is_a_usage_error_not_a_traceback(tmp_path, capsys):
    from tools.layout_load import main

    (tmp_path / "junk.mcap").write_bytes(b"not a trace")
    for path in (tmp_path / "missing.mcap", tmp_path / "junk.mcap"):
        with pytest.raises(SystemExit) as exc:
            main([str(path)])
        assert exc.value.code == 2 and str(path) in capsys.readouterr().err


def test_a_legged_layout_spreads_legs_over_buses_and_puts_sync_on_each():
    from tools.layout_load import layout_table, spread

    motors = {f"cybergear type {t} motor {m}": (250.0, 140.0, True) for t in (1, 2) for m in range(1, 13)}
    lockstep = {"0x080": (250.0, 86.0, True), "0x710": (250.0, 122.0, True)}
    table = {"can1": {**{k: v for k, v in motors.items() if int(k.split()[-1]) <= 6}, **lockstep,
                      "0x100": (500.0, 121.0, False)},
             "can2": {**{k: v for k, v in motors.items() if int(k.split()[-1]) > 6}, **lockstep}}
    four = spread(table, 4)
    for bus, legs in zip(four, ((1, 2, 3), (4, 5, 6), (7, 8, 9), (10, 11, 12))):
        assert {int(k.split()[-1]) for k in bus if k.startswith("cyber")} == set(legs)
        assert "0x080" in bus and "0x710" in bus
    assert "0x100" in four[0] and all("0x100" not in bus for bus in four[1:])
    one = spread(table, 1)[0]
    assert len(one) == 24 + 3
    rows = layout_table(table, 250.0, (1, 2), (250.0, 500.0))
    per_bus = (6 * 2 * 140 + 86 + 122) * 250 / 1e6  # a rear bus at 250 Hz
    assert rows[3].startswith(f"| 2 | {100 * (per_bus + 500 * 121 / 1e6):.1f} %")
    assert f"/ {100 * per_bus:.0f})" in rows[3]
