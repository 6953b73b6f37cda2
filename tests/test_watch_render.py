"""``wheelleg render``: a video of a run from its trace alone (offscreen MuJoCo), the poses it draws."""
from __future__ import annotations

import ctypes.util

import numpy as np
import pytest

from wheelleg.hil import cli
from wheelleg.hil.watch.scene import QPOS_PERIOD_S, recorded_motion

from sharing import same_run

pytestmark = same_run("jump 1.6 s")  # every test here draws from rig_run("jump", duration=1.6): one worker, one run
needs_gl = pytest.mark.skipif(not (ctypes.util.find_library("OSMesa") or ctypes.util.find_library("EGL")),
                              reason="no offscreen OpenGL: apt-get install libosmesa6 (.ci/run does)")


def test_a_run_records_its_poses_at_25_hz_and_they_match_ground_truth(rig_run):
    run = rig_run("jump", duration=1.6)
    motion = recorded_motion(run.trace_path)
    assert motion.qpos.shape == (len(motion.t_s), motion.model.nq)
    assert np.allclose(np.diff(motion.t_s)[1:], QPOS_PERIOD_S)
    assert 1.55 < motion.t_s[-1] + QPOS_PERIOD_S and motion.t_s[-1] <= 1.6
    state = run.state  # /sim/state each period: the body's x, z at the same instants
    at = np.searchsorted(state["t"], motion.t_s)
    assert np.allclose(motion.qpos[:, 0], state["x"][at], atol=1e-9)
    assert np.allclose(motion.qpos[:, 2], state["z"][at], atol=1e-9)
    assert motion.qpos[:, 2].max() > motion.qpos[0, 2] + 0.1  # the jump is in the poses


@needs_gl
@pytest.mark.slow
def test_render_writes_a_video_of_the_expected_frames_that_change_as_the_robot_jumps(rig_run, tmp_path):
    import imageio.v3 as iio

    run = rig_run("jump", duration=1.6)
    out = tmp_path / "jump.mp4"
    assert cli.main(["render", str(run.trace_path), "-o", str(out), "--from", "0.9", "--to", "1.5",
                     "--size", "160x120", "--fps", "10"]) == 0
    frames = iio.imread(out)
    assert frames.shape == (6, 120, 160, 3)
    assert frames.std() > 10  # not a blank picture
    change = [np.abs(a.astype(int) - b.astype(int)).mean() for a, b in zip(frames, frames[1:])]
    assert min(change) > 0.5, change  # every step of the jump moves the picture


@needs_gl
@pytest.mark.slow
def test_a_gif_and_a_single_frame(rig_run, tmp_path):
    from PIL import Image

    run = rig_run("jump", duration=1.6)
    gif, png = tmp_path / "j.gif", tmp_path / "j.png"
    assert cli.main(["render", str(run.trace_path), "-o", str(gif), "--from", "1.0", "--to", "1.2",
                     "--size", "64x48", "--fps", "20"]) == 0
    assert Image.open(gif).n_frames == 4 and Image.open(gif).size == (64, 48)
    assert cli.main(["render", str(run.trace_path), "-o", str(png), "--from", "1.3", "--size", "64x48"]) == 0
    assert Image.open(png).size == (64, 48)


def test_bad_input_is_one_line_and_exit_2(rig_run, tmp_path, capsys):
    run = rig_run("jump", duration=1.6)
    log = run.trace_path.with_suffix(".log")
    cases = [([str(log)], "not an MCAP trace"),
             ([str(tmp_path / "none.mcap")], "no such file"),
             ([str(run.trace_path), "-o", str(tmp_path / "x.avi")], "must be .mp4 or .gif"),
             ([str(run.trace_path), "--size", "7x5"], "must be even"),
             ([str(run.trace_path), "--from", "2", "--to", "1"], "nothing to draw")]
    for argv, message in cases:
        assert cli.main(["render", *argv]) == 2
        err = capsys.readouterr().err
        assert message in err and err.count("\n") == 1, err
    assert not (tmp_path / "x.avi").exists()


@needs_gl
@pytest.mark.slow
def test_the_run_png_gets_a_filmstrip_of_the_robot_at_its_events(rig_run, tmp_path):
    from PIL import Image

    from wheelleg.hil.analyze.plot import plot_run
    from wheelleg.hil.watch.clips import filmstrip_times

    run = rig_run("jump", duration=1.6)
    plain = np.asarray(Image.open(plot_run(run, tmp_path / "plain.png")).convert("RGB")).astype(int)
    strip = np.asarray(Image.open(plot_run(run, tmp_path / "strip.png", trace=run.trace_path)).convert("RGB")).astype(int)
    extra = strip.shape[0] - plain.shape[0]
    assert strip.shape[1] == plain.shape[1] and extra > 100  # a row above the four panels
    top = strip[: extra + 40]
    r, g, b = top[..., 0], top[..., 1], top[..., 2]
    assert ((b > r + 25) & (b >= g)).sum() > 5000  # MuJoCo's blue floor: pictures of the robot
    times = filmstrip_times(recorded_motion(run.trace_path))
    assert times[0] == pytest.approx(0.002) and len(times) == 6 and times == sorted(times)
    assert all(b - a > 0.25 for a, b in zip(times, times[1:]))
