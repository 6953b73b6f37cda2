"""``wheelleg campaign`` writes report.html: a page a browser opens from the file system with the pass
rates, the figures and each failure's video; headless Chromium looks at it as a person would."""
from __future__ import annotations

import ctypes.util
import json
import shutil
import subprocess

import numpy as np
import pytest

from wheelleg.hil import cli
from wheelleg.hil.watch.clips import CLIP_FPS, CLIP_SIZE, clip_span, failing_moment

pytestmark = pytest.mark.slow
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
HEADER_RGB = (238, 238, 255)  # report_html.STYLE's th background


def test_failing_moment_is_the_first_fall_else_the_last_event_and_the_clip_stays_in_the_run():
    t = np.linspace(0, 3, 301)
    upright = {"t": t, "pitch": np.zeros_like(t), "roll": np.zeros_like(t)}
    assert failing_moment(upright, [{"t": 0.5, "kind": "push"}, {"t": 2.0, "kind": "fault"}]) == 2.0
    falling = dict(upright, pitch=np.where(t > 1.2, 1.2, 0.0))
    assert failing_moment(falling, [{"t": 2.5, "kind": "fault"}]) == pytest.approx(1.21)
    assert clip_span(0.2, 0.0, 10.0) == (0.0, 2.5)
    assert clip_span(9.9, 0.0, 10.0) == (7.5, 10.0)
    assert clip_span(1.0, 0.0, 1.2) == (0.0, 1.2)


@pytest.mark.skipif(not ctypes.util.find_library("OSMesa") and not ctypes.util.find_library("EGL"),
                    reason="no offscreen OpenGL: apt-get install libosmesa6 (.ci/run does)")
@pytest.mark.skipif(CHROMIUM is None, reason="no chromium: apt-get install chromium (.ci/run does)")
def test_report_html_opens_in_a_browser_with_the_table_and_a_failure_video(tmp_path):
    import imageio.v3 as iio
    from PIL import Image

    out = tmp_path / "campaign"
    # fall cut at 1.2 s: it has fallen (0.93 s) but not stood up again: a failure; balance passes
    code = cli.main(["campaign", "fall", "balance", "--samples", "1", "--duration", "1.2", "--workers", "1",
                     "-q", "--out", str(out)])
    assert code == 1
    rows = {r["scenario"]: r for r in map(json.loads, (out / "results.jsonl").read_text().splitlines())}
    failed = rows["fall"]
    assert not failed["passed"] and rows["balance"]["passed"] and "video" not in rows["balance"]
    assert 0.8 < failed["moment_s"] < 1.1  # the fall, not the push at 0.5 s
    frames = iio.imread(out / failed["video"])
    assert frames.shape == (round(1.2 * CLIP_FPS), CLIP_SIZE[1], CLIP_SIZE[0], 3)

    page = out / "report.html"
    dom = subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--dump-dom", page.as_uri()],
                         capture_output=True, text=True, timeout=120).stdout
    assert '<table id="pass-rate">' in dom and "<td>fall</td>" in dom and "0.0%" in dom
    assert dom.count("<video") == 1 and 'src="data:video/mp4;base64,' in dom and "<svg" in dom
    assert failed["rerun"] in dom
    shot = tmp_path / "shot.png"
    subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                    "--window-size=1200,2400", f"--screenshot={shot}", page.as_uri()],
                   capture_output=True, timeout=120, cwd=tmp_path, check=True)
    pixels = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    header = np.all(pixels == HEADER_RGB, axis=2).sum()
    assert header > 2000, header  # the tables' header rows are drawn
    r, g, b = pixels[..., 0], pixels[..., 1], pixels[..., 2]
    scene = ((b > r + 25) & (b >= g) & (b < 250)).sum()  # MuJoCo's blue floor and sky: the video's poster
    assert scene > 0.3 * CLIP_SIZE[0] * CLIP_SIZE[1], scene
