"""``wheelleg run --view`` on a virtual screen (Xvfb): MuJoCo's viewer shows the robot while it runs, and
closing its window ends the run with its verdict; ``replay --view`` plays a trace's poses."""
from __future__ import annotations

import os
import subprocess
import sys
import time

import numpy as np
import pytest

import x11_helpers
from sharing import same_run

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(x11_helpers.available() is not None, reason=str(x11_helpers.available()))]
ORANGE_LEGS = ((180, 255), (80, 160), (0, 90))  # the model's legs, rgba 0.8 0.5 0.2, lit


def wheelleg(*argv: str, display: str) -> subprocess.Popen:
    env = dict(os.environ, DISPLAY=display)
    return subprocess.Popen([sys.executable, "-m", "wheelleg.hil.cli", *argv], env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def wait_for_window(screen: x11_helpers.Display, process: subprocess.Popen, timeout_s: float = 60) -> int:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and process.poll() is None:
        found = [w for name, w in screen.windows().items() if "MuJoCo" in name]
        if found:
            return found[0]
        time.sleep(0.2)
    process.kill()
    raise AssertionError(f"no MuJoCo window: {process.communicate()}")


def wait_for_robot(display: str, timeout_s: float = 90) -> np.ndarray:
    """A screenshot once the robot shows (software OpenGL on a loaded machine draws its first frames late)."""
    from PIL import ImageGrab

    deadline = time.monotonic() + timeout_s
    while True:
        shot = np.asarray(ImageGrab.grab(xdisplay=display).convert("RGB"))
        if orange_pixels(shot) > 200 or time.monotonic() > deadline:
            return shot
        time.sleep(0.5)


def orange_pixels(image: np.ndarray) -> int:
    r, g, b = (image[..., i].astype(int) for i in range(3))
    (r0, r1), (g0, g1), (b0, b1) = ORANGE_LEGS
    return int(((r >= r0) & (r <= r1) & (g >= g0) & (g <= g1) & (b >= b0) & (b <= b1)).sum())


def test_the_viewer_shows_the_robot_and_closing_it_ends_the_run_with_its_verdict(tmp_path):
    with x11_helpers.xvfb() as display:
        screen = x11_helpers.Display(display)
        try:
            run = wheelleg("run", "balance", "--view", "--out", str(tmp_path), "--no-plot", "-q", display=display)
            window = wait_for_window(screen, run)
            shot = wait_for_robot(display)
            screen.close_window(window)
            out, err = run.communicate(timeout=120)
        finally:
            screen.close()
    assert shot.std() > 10, "a uniform screen"
    assert orange_pixels(shot) > 200, "no robot (its orange legs) on the screen"
    assert run.returncode in (0, 1), err
    assert "the viewer was closed at" in err
    assert "balance: PASSED" in out or "balance: FAILED" in out
    ticks = int(out.split(" ticks")[0].split()[-1])
    assert 0 < ticks < 5000  # ended before the scenario's 10 s (5000 ticks of 2 ms): by the window's close
    from wheelleg.hil.record.rundata import load_run

    assert load_run(tmp_path / "balance.mcap").state["t"][-1] == pytest.approx(ticks * 0.002, abs=1e-9)


def test_view_without_a_display_is_a_one_line_usage_error(tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    done = subprocess.run([sys.executable, "-m", "wheelleg.hil.cli", "run", "balance", "--view", "--out",
                           str(tmp_path), "--no-plot", "-q"], env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "needs a display" in done.stderr and done.stderr.count("\n") == 1


@same_run("balance")  # test_scenarios_basic's run
def test_replay_view_shows_the_recorded_robot_after_its_verdict_until_closed(rig_run):
    trace = rig_run("balance").trace_path  # 10 s: the view plays it at real time and closes at its end
    with x11_helpers.xvfb() as display:
        screen = x11_helpers.Display(display)
        try:
            replay = wheelleg("replay", str(trace), "--view", display=display)
            window = wait_for_window(screen, replay)
            shot = wait_for_robot(display)
            screen.close_window(window)
            out, err = replay.communicate(timeout=120)
        finally:
            screen.close()
    assert replay.returncode == 0, err
    assert "identical" in out and orange_pixels(shot) > 200
