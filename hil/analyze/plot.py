"""One PNG per run: attitude, leg lengths (or body height), speed and torques over time."""
from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no screen
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from wheelleg.hil.run.scenario import RunData  # noqa: E402


def plot_run(run: RunData, path: Path | str, title: str = "", trace: Path | None = None) -> Path:
    """Write the four-panel overview of ``run`` to ``path``; with its ``trace``, a filmstrip row of the
    robot at its events above them (hil/watch/clips.py; left out, with a note, where nothing renders)."""
    s = run.state
    t = s["t"]
    stills = _stills(trace) if trace is not None else []
    fig = plt.figure(figsize=(10, 11 + (1.6 if stills else 0)))
    grid = fig.add_gridspec(5 if stills else 4, 1, height_ratios=[1.6, 2.5, 2.5, 2.5, 2.5] if stills else None)
    if stills:
        _filmstrip(fig, grid[0].subgridspec(1, len(stills)), stills)
    first = fig.add_subplot(grid[1 if stills else 0])
    axes = [first] + [fig.add_subplot(grid[i], sharex=first) for i in range(2 if stills else 1, 5 if stills else 4)]
    axes[0].plot(t, np.degrees(s["pitch"]), label="pitch")
    axes[0].plot(t, np.degrees(s["roll"]), label="roll")
    axes[0].set_ylabel("deg")
    legs = [k for k in s if k.endswith("_leg_length")]  # a robot without leg lengths: its body height
    for key in legs or ["z"]:
        axes[1].plot(t, s[key], label=key.removesuffix("_length").replace("_", " ") if legs else "body height")
    axes[1].set_ylabel("leg length (m)" if legs else "height (m)")
    speed = s["vx"] * np.cos(s["yaw"]) + s["vy"] * np.sin(s["yaw"])
    axes[2].plot(t, speed, label="forward speed (m/s)")
    axes[2].plot(t, np.unwrap(s["yaw"]) - s["yaw"][0], label="yaw turned (rad)")
    axes[2].set_ylabel("m/s, rad")
    for motor, (tt, tau) in sorted(run.hip_torque.items()):
        axes[3].plot(tt, tau, lw=0.7, label=f"motor {motor}")
    for esc, (tt, amps) in sorted(run.wheel_current.items()):
        if np.any(amps):
            axes[3].plot(tt, amps * 0.3, lw=0.7, ls="--", label=f"wheel {esc}")
    axes[3].set_ylabel("commanded torque (N m)")
    axes[3].set_xlabel("time (s)")
    for event in run.events:
        if event.get("kind") not in ("operator",):
            for ax in axes:
                ax.axvline(event["t"], color="grey", lw=0.5, alpha=0.5)
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=7)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return Path(path)


def _stills(trace: Path) -> list:
    """(t s, image) of the run's filmstrip, [] with a one-line note on stderr when it cannot be drawn."""
    from wheelleg.hil.watch.clips import filmstrip  # noqa: PLC0415 (MuJoCo's renderer only when drawing)
    from wheelleg.hil.watch.render import RenderError, SceneError  # noqa: PLC0415

    try:
        return filmstrip(trace)
    except (RenderError, SceneError) as exc:
        print(f"plot: no filmstrip: {exc}", file=sys.stderr)
        return []


def _filmstrip(fig, cells, stills: list) -> None:
    for cell, (t_s, image) in zip(cells, stills):
        ax = fig.add_subplot(cell)
        ax.imshow(image)
        ax.set_axis_off()
        ax.set_title(f"{t_s:.2f} s", fontsize=8)
