"""The trace as a bug report: does it carry what replay needs, and where does this machine differ?

A rig trace records the run (scenario, seed, control period, bus channels, git
revision, controller parameters and plant overrides as JSON) and attaches the
DBC files and the MJCF, so another engineer can replay it elsewhere, or rerun
it with the same plant (``rerun_command``). ``bug_report_gaps`` lists
what a trace lacks; ``environment_warnings`` lists where the installed tree
differs from the recording (DBC files, revision, parameters), since replay
runs today's controller with today's DBC files.
"""
from __future__ import annotations

import json

from wheelleg import dbc
from wheelleg.hil import robots
from wheelleg.hil.record.run_metadata import REPLAY_KEYS, git_revision
from wheelleg.hil.record.sources import Recording




def installed_dbcs(robot: str) -> dict:
    """File name -> path of every DBC file installed for a recording of ``robot``: the rig's (dbc/) and its
    robot's own (``Robot.dbc_paths``: a plug-in's in its package), as a run attaches them."""
    files = {p.name: p for p in dbc.all_dbc_files()}
    files.update({p.name: p for p in robots.get(robot).dbc_paths()})
    return files


def bug_report_gaps(source: Recording) -> list[str]:
    """What the trace lacks to be replayed on another machine ([] for a complete rig trace)."""
    if source.kind != "mcap":
        return ["a candump log carries no DBC files, MJCF, parameters, scenario, seed or revision: "
                "replay uses what is installed here"]
    gaps = [f"run metadata '{key}'" for key in REPLAY_KEYS if not source.run.get(key)]
    gaps += [f"attachment {name}" for name in installed_dbcs(source.robot) if name not in source.attachments]
    if not any(name.endswith(".xml") for name in source.attachments):
        gaps.append("MJCF attachment (*.xml)")
    return gaps


def environment_warnings(source: Recording) -> list[str]:
    """Where this machine differs from the one that recorded: DBC files, revision, parameters."""
    out = [f"trace lacks {gap}" for gap in bug_report_gaps(source)] if source.kind == "mcap" else []
    installed = installed_dbcs(source.robot)
    for name, data in sorted(source.attachments.items()):
        if not name.endswith(".dbc"):
            continue
        if name not in installed:
            out.append(f"the trace's {name} is not installed (replay uses the installed files)")
        elif installed[name].read_bytes() != data:
            out.append(f"the trace's {name} differs from the installed {installed[name]}: replay encodes and "
                       "decodes with the installed one, so ids or scales may have changed")
    recorded = source.run.get("git_revision")
    here = git_revision()
    if recorded and recorded != "unknown" and here != "unknown" and recorded != here:
        out.append(f"recorded at git revision {recorded[:12]}, this tree is at {here[:12]}")
    out += _param_warnings(source)
    return out


def _param_warnings(source: Recording) -> list[str]:
    text = source.run.get("controller_params")
    if not text:
        return []
    try:
        recorded = json.loads(text)
    except ValueError:
        return ["the trace's controller_params is not JSON"]
    now = json.loads(robots.get(source.robot).params_json())  # the recording's robot's controller today
    changed = [f"{k}: {recorded.get(k)!r} -> {now.get(k)!r}" for k in sorted(set(recorded) | set(now))
               if recorded.get(k) != now.get(k)]
    return [f"controller parameters differ from the recording: {', '.join(changed)}"] if changed else []
