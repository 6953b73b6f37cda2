"""What the controller does under the faults no scenario checks: ``python -m tools.fault_survey``.

Each entry balances on flat ground, injects one fault at 1 s for the rest of
the run and reports, from the trace, the modes the controller went through,
when it first changed mode, how far the body pitched and the largest offline
mask. A markdown table, for docs/measurements.md's fault table; not a pass/fail check
(the scenarios in hil/scenarios/faults.py are those).
"""
from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from wheelleg.controller.modes import Mode
from wheelleg.hil.run import faults as F
from wheelleg.hil.run.rig import Rig, RigConfig
from wheelleg.hil.record.rundata import load_run
from wheelleg.hil.run.scenario import Scenario
from wheelleg.hil.scenarios.basic import standing
from wheelleg.hil.scenarios.common import stand

AT = 1.0  # s

SURVEY = {  # name -> (what, actions)
    "frozen-joint": ("left_front_hip repeats its last reply", F.frozen("left_front_hip", AT)),
    "frozen-wheel": ("left wheel C620 repeats its last feedback", F.frozen("left_wheel", AT)),
    "esc-hold": ("left wheel C620 ignores commands, holds its current", F.esc_hold("left_wheel", AT)),
    "late-replies": ("CAN2 replies 5 ms late + 0-2 ms jitter", F.frame_delay("can2", AT, None, 0.005, 0.002)),
    "jitter-can1": ("CAN1 frames 0-3 ms jitter", F.frame_delay("can1", AT, None, 0.0, 0.003)),
    "corrupt-can1": ("1 % of CAN1 frames with one bit flipped", F.frame_corruption("can1", AT, None, 0.01)),
    "corrupt-can2": ("1 % of CAN2 frames with one bit flipped", F.frame_corruption("can2", AT, None, 0.01)),
    "error-frames": ("an error frame after 10 % of the frames, both buses",
                     F.error_frames("can1", AT, None, 0.1) + F.error_frames("can2", AT, None, 0.1)),
    "loss-20pc-can2": ("20 % of CAN2 frames lost both ways", F.frame_loss("can2", AT, None, 0.2, direction=F.BOTH)),
    "imu-bias": ("IMU pitch-rate bias 0.05 rad/s", F.imu_bias(AT, None, gyro_bias_rad_s=(0.0, 0.05, 0.0))),
    "imu-noise": ("IMU noise x10", F.imu_noise(AT, None, gyro_std_rad_s=0.04, accel_std_m_s2=0.25,
                                               attitude_std_rad=0.02)),
    "imu-spikes": ("1 % of IMU samples with a 20 rad/s spike on one axis",
                   F.imu_spikes(AT, None, probability=0.01, magnitude_rad_s=20.0)),
}


def survey(name: str, duration_s: float, out: Path, seed: int = 0) -> dict:
    what, actions = SURVEY[name]
    scenario = Scenario(name, what, duration_s, standing(), timeline=(stand(), *actions))
    outcome = Rig(scenario, RigConfig(seed=seed), out / name).run()
    run = load_run(outcome.trace_path)
    hb = run.heartbeat
    after = hb["t"] >= AT
    modes = hb["Mode"][after]
    changed = hb["t"][after][modes != modes[0]]
    return {"name": name, "what": what, "modes": [Mode(int(m)).name for m in dict.fromkeys(modes)],
            "first_change_ms": (changed[0] - AT) * 1000 if len(changed) else None,
            "max_pitch_deg": float(np.degrees(np.max(np.abs(run.window("pitch", AT))))),
            "mask": int(np.max(hb["OfflineMask"][after])), "deadline_misses": outcome.deadline_misses}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tools.fault_survey", description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", help=f"entries (default all: {', '.join(SURVEY)})")
    parser.add_argument("--duration", type=float, default=3.0, help="s per run (fault at 1 s)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    unknown = set(args.names) - set(SURVEY)
    if unknown:
        parser.error(f"unknown entries {sorted(unknown)}; known: {', '.join(SURVEY)}")
    print("| fault | modes after it | first mode change | max pitch | offline mask |")
    print("|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.names or SURVEY:
            r = survey(name, args.duration, Path(tmp), args.seed)
            change = f"{r['first_change_ms']:.1f} ms" if r["first_change_ms"] is not None else "none"
            print(f"| {r['what']} | {' -> '.join(r['modes'])} | {change} | {r['max_pitch_deg']:.2f} deg "
                  f"| 0x{r['mask']:02x} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
