"""One PNG per run: attitude, leg lengths (or body height), speed and torques over time."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no screen
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from wheelleg.hil.run.scenario import RunData  # noqa: E402


def plot_run(run: RunData, path: Path | str, title: str = "") -> Path:
    """Write the four-panel overview of ``run`` to ``path``."""
    s = run.state
    t = s["t"]
    fig, axes = plt.subplots(4, 1, figsize=(10, 11), sharex=True)
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
