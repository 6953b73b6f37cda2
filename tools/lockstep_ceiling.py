"""The fastest any rig could run a scenario in lockstep: the robot's program and MuJoCo alone.

    python -m tools.lockstep_ceiling [SCENARIO] [--duration S] [--reps N]

A lockstep tick cannot be shorter than what it must do whatever the rig is
made of: the robot's program reads its frames and computes its tick (its
inputs come from the one before: nothing to overlap), and MuJoCo steps the
physics of the control period. This measures, per control tick (best of
``--reps``, one scenario captured once with ``tools.controller_replay``):

- the program alone: its captured inputs fed to ``on_frame``/``tick``;
- the program on its buses: the same inputs as ``can.Message`` frames that a
  player sends through the rig's in-process bus (``LockstepVirtualBus``) to
  the program's own ``CanNode``, whose frames the player takes off again:
  the frame contract (python-can frames both ways) at its least, no devices,
  no wire model, no record;
- MuJoCo alone stepping the scenario's model for the period.

and prints the ceiling (period / (program on its buses + MuJoCo)) beside the
rig's own figure (``tools.bench``), and what a tick leaves the rig for its
devices, bus, wire model and record at 10x real time. Each tick's outputs on
the buses are compared with the captured run's: exit 1 when one differs.
"""
from __future__ import annotations

import argparse
import time
from dataclasses import dataclass, replace

import mujoco

from tools import known_scenario
from tools.controller_replay import capture_events, message, replay_events, tick_outputs
from wheelleg.hil import robots, scenarios
from wheelleg.hil.bus.transport import open_bus
from wheelleg.hil.run.rig import RigConfig


def mujoco_only(scenario, sim_s: float) -> dict:
    """MuJoCo stepping the scenario's model (same terrain, same timestep) for ``sim_s``, nothing else."""
    physics = robots.get(scenario.robot).build_physics(scenario.terrain, RigConfig.physics_dt_s, {})
    scenario.start(physics)
    model, data = physics.model, physics.data
    steps = round(sim_s / model.opt.timestep)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    return {"sim_s": sim_s, "wall_s": time.perf_counter() - wall0, "cpu_s": time.process_time() - cpu0,
            "us_per_step": 1e6 * (time.perf_counter() - wall0) / steps}


def on_buses(captured: dict, robot, period_s: float, reps: int) -> tuple[float, int]:
    """The program in its ``CanNode`` on in-process bus pairs, fed the captured frames by a
    player: (best s a tick, ticks whose outputs differ from the capture's)."""
    ticks = [e for e in captured["events"] if e[0] == "tick"]
    best, differ = float("inf"), 0
    for rep in range(reps):
        names = {role: f"ceiling-{rep}-{role}" for role in robot.roles}
        player = {bus: open_bus("virtual", name) for bus, name in names.items()}
        node = robot.build_controller({bus: open_bus("virtual", name) for bus, name in names.items()}, True, period_s)
        for end in player.values():
            end.take_as_sent()
        sends = {bus: end.send_owned for bus, end in player.items()}
        polls = tuple(end.poll for end in player.values())
        results = []
        start = time.perf_counter()
        for kind, a, b, _ in captured["events"]:
            if kind == "frame":
                sends[b](message(a))
            else:
                node.service()
                results.append(node.last_result)
                for poll in polls:
                    while poll() is not None:
                        pass
        best = min(best, time.perf_counter() - start)
        differ = sum(tick_outputs(r) != e[3] for r, e in zip(results, ticks)) + abs(len(results) - len(ticks))
        for end in (*player.values(), *node.buses.values()):
            end.shutdown()
    return best / max(1, len(ticks)), differ


@dataclass(frozen=True)
class Ceiling:
    """A scenario's tick at its least, best of the repetitions: s a tick of each part."""

    name: str
    ticks: int
    period_s: float
    alone_s: float  # the program alone
    bused_s: float  # the program on its buses
    physics_s: float  # MuJoCo alone for the period
    identical: bool  # every tick's outputs as in the captured run, both ways

    @property
    def factor(self) -> float:
        """The real-time factor of a rig that costs nothing."""
        return self.period_s / (self.bused_s + self.physics_s)


def measure(name: str, duration_s: float, reps: int) -> Ceiling:
    """Capture ``name`` for ``duration_s`` (s), then time the program alone, on its buses and MuJoCo."""
    scenario = replace(scenarios.get(name), duration_s=duration_s)
    robot = robots.get(scenario.robot)
    period_s = robot.control_period_s
    captured = capture_events(name, duration_s)
    ticks, alone_s, differ_alone = replay_events(captured, reps)
    bused_s, differ_bused = on_buses(captured, robot, period_s, reps)
    physics = min((mujoco_only(scenario, duration_s) for _ in range(reps)), key=lambda r: r["wall_s"])
    return Ceiling(scenario.name, ticks, period_s, alone_s, bused_s, physics["wall_s"] / ticks,
                   not differ_alone and not differ_bused)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario", nargs="?", default="balance", type=known_scenario)
    parser.add_argument("--duration", type=float, default=5.0, help="simulated seconds (default 5)")
    parser.add_argument("--reps", type=int, default=3, help="repetitions, the best kept (default 3)")
    args = parser.parse_args(argv)
    c = measure(args.scenario, args.duration, max(1, args.reps))
    floor_s = c.bused_s + c.physics_s
    print(f"{c.name}: {c.ticks} ticks of {1e3 * c.period_s:g} ms, best of {args.reps}, wall us a tick:")
    print(f"  the program alone              {1e6 * c.alone_s:8.1f}")
    print(f"  the program on its buses       {1e6 * c.bused_s:8.1f}  (python-can frames both ways)")
    print(f"  MuJoCo alone, the period       {1e6 * c.physics_s:8.1f}")
    print(f"ceiling: {c.factor:.1f}x real time for any rig around this program "
          f"({1e6 * floor_s:.1f} us a tick before the rig does anything)")
    budget_s = c.period_s / 10 - floor_s
    print(f"at 10x the rig's devices, bus, wire model and record would have {1e6 * budget_s:.1f} us a tick"
          + ("" if budget_s > 0 else ": none, 10x is out of reach for this program"))
    if not c.identical:
        print("OUTPUTS DIFFER from the captured run (the program alone or on its buses)")
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
