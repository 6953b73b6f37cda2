"""``--view``: MuJoCo's own (passive) viewer follows a run, or a recorded run's poses (``replay --view``).

The viewer draws the plant's live ``MjData`` in its own thread; the rig calls
``RunViewer.on_state`` once per control period (``Rig.watchers``), which paces
the run to wall time (unless ``fast``) and hands the viewer the new state at
most ``SYNC_HZ`` times a second. Closing the window asks the rig to stop
(``Rig.stop_requested``): the run ends at that tick and is judged as it stands.
Needs a display (X11 or Wayland; ``xvfb-run`` for none); the rig's
``MUJOCO_GL=disable`` does not concern the viewer (it opens its window through glfw).
"""
from __future__ import annotations

import os
import time

import mujoco

SYNC_HZ = 60.0  # the viewer's picture is refreshed at most this often (wall)
CAMERA = (90.0, -15.0, 1.3)  # azimuth deg, elevation deg, distance m: from the side, following the body
CLOSE_WAIT_S = 3.0  # how long ``close`` waits for the viewer's thread to end


class ViewerError(Exception):
    """The viewer cannot open: one line."""


def open_viewer(model: mujoco.MjModel, data: mujoco.MjData):
    """MuJoCo's passive viewer on ``model``/``data``, camera following the body; ViewerError without a display."""
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise ViewerError("--view needs a display (DISPLAY is not set): run under xvfb-run, use --live, "
                          "or `wheelleg render` the trace afterwards")
    try:
        import mujoco.viewer  # noqa: PLC0415 (glfw only when a window is asked for)

        handle = mujoco.viewer.launch_passive(model, data, show_left_ui=False, show_right_ui=False)
    except Exception as exc:  # noqa: BLE001 - glfw's or the display's own failure, one line
        raise ViewerError(f"cannot open MuJoCo's viewer: {exc}".splitlines()[0]) from exc
    with handle.lock():
        handle.opt.geomgroup[:4] = 1  # the collision geoms too: the body box and the wheels
        body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "body")
        if body >= 0:
            handle.cam.type = mujoco.mjtCamera.mjCAMERA_TRACKING
            handle.cam.trackbodyid = body
        handle.cam.azimuth, handle.cam.elevation, handle.cam.distance = CAMERA
    return handle


def close_viewer(handle) -> None:
    """Close the window and wait (``CLOSE_WAIT_S`` at most) for the viewer's thread to end."""
    handle.close()
    deadline = time.monotonic() + CLOSE_WAIT_S
    while handle.is_running() and time.monotonic() < deadline:
        time.sleep(0.02)


class Pacer:
    """Holds simulated time to wall time (unless ``fast``) and says when a picture is due."""

    def __init__(self, fast: bool):
        self.fast = fast
        self._wall0: float | None = None
        self._last_sync = -1.0

    def wait(self, t_s: float) -> bool:
        """Sleep until wall time reaches simulated ``t_s`` (paced); True when the viewer should be synced."""
        now = time.perf_counter()
        if self._wall0 is None:
            self._wall0 = now - t_s
        if not self.fast:
            ahead = self._wall0 + t_s - now
            if ahead > 0:
                time.sleep(ahead)
                now += ahead
        if now - self._last_sync >= 1.0 / SYNC_HZ:
            self._last_sync = now
            return True
        return False


class RunViewer:
    """The viewer as a rig watcher (``Rig.watchers``)."""

    def __init__(self, rig, fast: bool = False):
        self.handle = open_viewer(rig.physics.model, rig.physics.data)
        self.pacer = Pacer(fast)

    def on_state(self, rig, state: dict) -> None:
        if not self.handle.is_running():  # the window was closed
            rig.stop_requested = True
            return
        if self.pacer.wait(rig.clock.now_ns / 1e9):
            self.handle.sync()

    def close(self) -> None:
        close_viewer(self.handle)


def play_motion(motion, fast: bool = False) -> bool:
    """Show a recorded run's poses (``scene.RecordedMotion``) in the viewer, paced; True if played to the end,
    False if the window was closed first."""
    data = mujoco.MjData(motion.model)
    handle = open_viewer(motion.model, data)
    pacer = Pacer(fast)
    try:
        for t_s, qpos in zip(motion.t_s.tolist(), motion.qpos):
            if not handle.is_running():
                return False
            with handle.lock():
                data.qpos[:] = qpos
                data.time = t_s
                mujoco.mj_forward(motion.model, data)
            pacer.wait(t_s)
            handle.sync()
        return True
    finally:
        close_viewer(handle)
