"""Each program's own microseconds a tick on the same recorded inputs: the Python program
(``Controller.on_frame`` + ``tick``) and the firmware's lockstep library (``wl_step``, its
inputs put in C arrays beforehand, the ctypes call's own cost measured apart).

    python -m tools.firmware_speed [LOG] [--reps N]

LOG defaults to tests/traces/balance-1s.log.gz. The firmware's figure is what an MCU's
budget is planned from (docs/firmware.md, the MCU port); the machine's load makes both
noisy: the best of ``--reps`` passes is reported.
"""
from __future__ import annotations

import argparse
import sys
import time

sys.path.insert(0, "tests")
from firmware_feed import Firmware, WlFrame, python_step, recorded_ticks, rx_arrays  # noqa: E402

from wheelleg.controller.node import Controller  # noqa: E402
from wheelleg.hil import firmware_build  # noqa: E402


def python_us(ticks) -> float:
    controller = Controller(record_debug=False)
    start = time.perf_counter()
    for tick in ticks:
        python_step(controller, tick)
    return 1e6 * (time.perf_counter() - start) / len(ticks)


def firmware_us(fw: Firmware, ticks) -> tuple[float, float]:
    """(us per wl_step, us per empty ctypes call of the same library)."""
    lib = fw.lib
    prepared = []
    for tick in ticks:
        prepared.append((tick.now_us, *rx_arrays(tick)))
    tx = (WlFrame * 64)()
    lib.wl_init(2000)
    step = lib.wl_step
    start = time.perf_counter()
    for now_us, rx, times, n in prepared:
        step(now_us, rx, times, n, tx, 64)
    per_step = 1e6 * (time.perf_counter() - start) / len(prepared)
    start = time.perf_counter()
    for _ in prepared:
        lib.wl_abi_version()
    return per_step, 1e6 * (time.perf_counter() - start) / len(prepared)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("log", nargs="?", default="tests/traces/balance-1s.log.gz")
    parser.add_argument("--reps", type=int, default=5)
    args = parser.parse_args(argv)
    ticks = recorded_ticks(args.log)
    fw = Firmware(firmware_build.build("lib"))
    py = min(python_us(ticks) for _ in range(args.reps))
    fw_runs = [firmware_us(fw, ticks) for _ in range(args.reps)]
    step, call = min(r[0] for r in fw_runs), min(r[1] for r in fw_runs)
    print(f"{args.log}: {len(ticks)} ticks, best of {args.reps}")
    print(f"  Python program  {py:8.1f} us per tick (on_frame + tick)")
    print(f"  firmware        {step:8.1f} us per wl_step ({call:.1f} us of it the ctypes call); "
          f"{step - call:.1f} us its own")
    print(f"  ratio           {py / max(step - call, 1e-9):8.1f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
