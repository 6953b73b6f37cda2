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
