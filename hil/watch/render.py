"""Offscreen frames and videos of a run, from its trace alone (``/sim/qpos``: scene.py).

MuJoCo's own renderer on an offscreen OpenGL: OSMesa (Debian libosmesa6, pure
software, everywhere) or EGL (libegl1 + a driver: a GPU's, or Mesa's). The rig
sets ``MUJOCO_GL=disable`` for speed (hil/cli.py); ``offscreen_gl`` picks a
back end only when a frame is asked for, so a run that draws nothing loads no GL.
``MUJOCO_GL=egl`` or ``osmesa`` set by the user is kept.

Videos: MP4 (H.264) through imageio-ffmpeg (it ships its own ffmpeg), GIF through
Pillow. Each frame carries the scenario, the time and the latest event.
"""
from __future__ import annotations

import ctypes.util
import importlib
import os
import sys
from pathlib import Path
from typing import Iterable, Iterator

import mujoco
import numpy as np

from wheelleg.hil.watch.scene import RecordedMotion, SceneError, recorded_motion

BACKENDS = {"osmesa": ("OSMesa", "libosmesa6"), "egl": ("EGL", "libegl1 libegl-mesa0")}  # name: (library, Debian)
CAMERAS = {  # name: (azimuth deg, elevation deg, distance m); the camera looks at the body, from the side by default
    "side": (90.0, -10.0, 1.0),
    "front": (180.0, -10.0, 1.0),
    "iso": (135.0, -25.0, 1.2),
    "top": (90.0, -89.0, 1.5),
}
LOOKAT_Z_M = 0.2  # the camera's lowest aim (m): on the ground the horizon stays put; it rises with a jump
EVENT_SHOWN_S = 0.6  # an event's name stays on the frames this long after it
IGNORED_EVENTS = ("operator",)  # the remote's set points: every tick's news, nobody's headline


_GL_LOADED: dict[str, str] = {}  # "backend": the MUJOCO_GL this process last reloaded mujoco's GL context for


class RenderError(Exception):
    """Nothing can be drawn here or from this trace: one line."""


def offscreen_gl() -> str:
    """Make MuJoCo's renderer use an offscreen OpenGL; its name ('osmesa' or 'egl'), else RenderError."""
    chosen = os.environ.get("MUJOCO_GL", "").lower()
    if chosen not in BACKENDS:
        chosen = next((name for name, (lib, _) in BACKENDS.items() if ctypes.util.find_library(lib)), None)
        if chosen is None:
            raise RenderError(f"no offscreen OpenGL for MuJoCo's renderer: install Debian's {BACKENDS['osmesa'][1]} "
                              f"(apt-get install {BACKENDS['osmesa'][1]}), or {BACKENDS['egl'][1]}")
    already = os.environ.get("PYOPENGL_PLATFORM")
    if "OpenGL" in sys.modules and already not in (None, chosen):
        raise RenderError(f"OpenGL is already loaded for {already!r} in this process, not {chosen!r}")
    os.environ["MUJOCO_GL"] = os.environ["PYOPENGL_PLATFORM"] = chosen
    from mujoco.rendering.classic import gl_context  # noqa: PLC0415 (read MUJOCO_GL when the rig disabled it)

    # mujoco read MUJOCO_GL once, on import (the rig's "disable": no GLContext); read it again now,
    # unless this process already made it load the chosen back end
    if getattr(gl_context, "GLContext", None) is None or _GL_LOADED.get("backend") != chosen:
        importlib.reload(gl_context)
        _GL_LOADED["backend"] = chosen
    return chosen


def _camera(model: mujoco.MjModel, name: str) -> mujoco.MjvCamera | int:
    """A preset (``CAMERAS``, aimed at the body each frame) as an MjvCamera, or a model camera's id."""
    if name in CAMERAS:
        cam = mujoco.MjvCamera()
        cam.type = mujoco.mjtCamera.mjCAMERA_FREE
        cam.azimuth, cam.elevation, cam.distance = CAMERAS[name]
        return cam
    cam_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, name)
    if cam_id < 0:
        known = [model.cam(i).name for i in range(model.ncam)]
        raise RenderError(f"no camera {name!r}: the presets {', '.join(CAMERAS)} or the model's {known}")
    return cam_id


def scene_options() -> mujoco.MjvOption:
    """What to draw: the visual geoms and the collision ones too (body box, wheels: geom group 3)."""
    options = mujoco.MjvOption()
    options.geomgroup[:4] = 1
    return options


class FrameRenderer:
    """Draws a model at given poses offscreen; a context manager (frees the GL context)."""

    def __init__(self, model: mujoco.MjModel, width: int = 480, height: int = 360, camera: str = "side"):
        offscreen_gl()
        from mujoco.rendering.classic.renderer import Renderer  # noqa: PLC0415 (after the back end is chosen)

        model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
        model.vis.global_.offheight = max(model.vis.global_.offheight, height)
        self.model, self.data = model, mujoco.MjData(model)
        self.camera = _camera(model, camera)
        self.options = scene_options()
        try:
            self._renderer = Renderer(model, height, width)
        except Exception as exc:  # noqa: BLE001 - the GL library's own failure, whichever it is
            raise RenderError(f"cannot open an offscreen OpenGL context ({os.environ['MUJOCO_GL']}): {exc}") from exc
        self._body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "body")

    def frame(self, qpos: np.ndarray, label: str = "") -> np.ndarray:
        """The image (height, width, 3) uint8 of the model at ``qpos`` (nq,), ``label`` drawn top left."""
        self.data.qpos[:] = qpos
        mujoco.mj_forward(self.model, self.data)
        if isinstance(self.camera, mujoco.MjvCamera) and self._body >= 0:
            x, y, z = self.data.xpos[self._body]
            self.camera.lookat[:] = (x, y, max(LOOKAT_Z_M, z - 0.05))
        self._renderer.update_scene(self.data, camera=self.camera, scene_option=self.options)
        image = self._renderer.render()
        return _labelled(image, label) if label else image

    def close(self) -> None:
        self._renderer.close()

    def __enter__(self) -> "FrameRenderer":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _labelled(image: np.ndarray, text: str) -> np.ndarray:
    from PIL import Image, ImageDraw  # noqa: PLC0415

    picture = Image.fromarray(image)
    draw = ImageDraw.Draw(picture)
    draw.rectangle((0, 0, 8 + 6 * len(text), 16), fill=(0, 0, 0))
    draw.text((4, 2), text, fill=(255, 255, 255))
    return np.asarray(picture)


def frame_times(t_from: float, t_to: float, fps: float) -> np.ndarray:
    """The video's frame times (s): ``round((t_to - t_from) * fps)`` of them (at least 1), from ``t_from``."""
    count = max(1, round((t_to - t_from) * fps))
    return t_from + np.arange(count) / fps


def _label(motion: RecordedMotion, t_s: float) -> str:
    recent = [e["kind"] for e in motion.events
              if e.get("kind") not in IGNORED_EVENTS and t_s - EVENT_SHOWN_S <= e["t"] <= t_s]
    return f"{motion.scenario}  t = {t_s:5.2f} s" + (f"  {recent[-1]}" if recent else "")


def motion_frames(motion: RecordedMotion, times: Iterable[float], renderer: FrameRenderer,
                  labelled: bool = True) -> Iterator[np.ndarray]:
    """One image per time in ``times`` (the last recorded pose at or before it), ``labelled`` with the
    scenario, the time and the latest event."""
    for t_s in times:
        yield renderer.frame(motion.qpos[motion.index_at(t_s)], _label(motion, float(t_s)) if labelled else "")


def write_video(path: Path, frames: Iterable[np.ndarray], fps: float) -> int:
    """``frames`` into ``path`` (.mp4: H.264, .gif: Pillow, .png: the first frame); the number written."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".gif":
        from PIL import Image  # noqa: PLC0415

        pictures = [Image.fromarray(f) for f in frames]
        if pictures:
            pictures[0].save(path, save_all=True, append_images=pictures[1:], duration=round(1000 / fps), loop=0)
        return len(pictures)
    if suffix == ".png":
        from PIL import Image  # noqa: PLC0415

        Image.fromarray(next(iter(frames))).save(path, optimize=True)
        return 1
    if suffix != ".mp4":
        raise RenderError(f"{path.name}: the video must be .mp4 or .gif")
    import imageio.v2 as imageio  # noqa: PLC0415 (imageio-ffmpeg's own ffmpeg)

    count = 0
    with imageio.get_writer(path, fps=fps, codec="libx264", quality=6, macro_block_size=8,
                            ffmpeg_log_level="error", output_params=["-movflags", "+faststart"]) as writer:
        for image in frames:
            writer.append_data(image)
            count += 1
    return count


def render_trace(trace: Path, out: Path, t_from: float | None = None, t_to: float | None = None,
                 camera: str = "side", fps: float = 25.0, size: tuple[int, int] = (480, 360)) -> int:
    """A video of ``trace`` from ``t_from`` to ``t_to`` (s; default the whole run) into ``out``; frames written.

    RenderError or SceneError (one line) for a trace or a request that cannot be drawn."""
    suffix = out.suffix.lower()
    if suffix not in (".mp4", ".gif", ".png"):
        raise RenderError(f"{out.name}: the video must be .mp4 or .gif (or .png: one frame at --from)")
    motion = recorded_motion(trace)
    start = motion.t_s[0] if t_from is None else t_from
    end = motion.t_s[-1] if t_to is None else t_to
    if suffix == ".png":
        end = start + 1 / fps
    if not (end > start and start <= motion.t_s[-1]):
        raise RenderError(f"nothing to draw from {start:g} s to {end:g} s (the run spans "
                          f"{motion.t_s[0]:g}..{motion.t_s[-1]:g} s)")
    out.parent.mkdir(parents=True, exist_ok=True)
    with FrameRenderer(motion.model, *size, camera=camera) as renderer:
        return write_video(out, motion_frames(motion, frame_times(start, end, fps), renderer), fps)


__all__ = ["FrameRenderer", "RenderError", "SceneError", "frame_times", "motion_frames", "offscreen_gl",
           "render_trace", "write_video"]
