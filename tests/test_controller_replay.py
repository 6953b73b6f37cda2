"""tools/controller_replay.py: a captured run replays to the same outputs, and a changed output is caught."""
import pickle

from tools import controller_replay


def test_a_capture_replays_identically_and_a_changed_output_fails(tmp_path, capsys):
    path = tmp_path / "balance.pkl"
    assert controller_replay.main(["capture", "balance", str(path), "--duration", "0.1"]) == 0
    assert controller_replay.main(["replay", str(path), "--reps", "1"]) == 0
    assert "50 ticks" in capsys.readouterr().out.splitlines()[-1]
    captured = pickle.loads(path.read_bytes())
    ticks = [i for i, event in enumerate(captured["events"]) if event[0] == "tick"]
    kind, number, now_s, (mode, frames, debug) = captured["events"][ticks[-1]]
    captured["events"][ticks[-1]] = (kind, number, now_s, (mode + 1, frames, debug))
    path.write_bytes(pickle.dumps(captured))
    assert controller_replay.main(["replay", str(path), "--reps", "1"]) == 1
    assert "OUTPUTS DIFFER in 1 ticks" in capsys.readouterr().out


def test_the_ceiling_runs_the_program_on_its_buses_to_the_captured_outputs():
    from tools import lockstep_ceiling
    from wheelleg.hil import robots

    captured = controller_replay.capture_events("balance", 0.1)
    robot = robots.get("wheel-legged")
    seconds, differ = lockstep_ceiling.on_buses(captured, robot, robot.control_period_s, reps=1)
    assert differ == 0 and seconds > 0
    ticks = [i for i, event in enumerate(captured["events"]) if event[0] == "tick"]
    syncs = [i for i, event in enumerate(captured["events"][:ticks[25]]) if event[0] == "frame" and event[1][1] == 0x080]
    del captured["events"][syncs[-1]]  # one bus's SYNC the player no longer sends: tick 25 cannot run
    assert lockstep_ceiling.on_buses(captured, robot, robot.control_period_s, reps=1)[1] > 0
