"""The Foxglove layout that ships with the package (``foxglove_layout.json``; ``wheelleg layout`` prints
its path): the 3D view of /scene, the key plots of ground truth and the controller, the scenario's events.

Built with the Foxglove SDK's layout classes (``foxglove.layouts``); ``python -m wheelleg.hil.watch.layout``
writes the file again, and a test checks the shipped one is what this builds.
"""
from __future__ import annotations

from pathlib import Path

LAYOUT_PATH = Path(__file__).with_name("foxglove_layout.json")
PLOTS = {  # panel title -> (message path, label) of each series: truth beside the controller's belief
    "attitude (rad)": [("/sim/state.pitch", "pitch (truth)"), ("/controller/debug.pitch", "pitch (IMU)"),
                       ("/sim/state.roll", "roll (truth)")],
    "legs (m)": [("/sim/state.left_leg_length", "left (truth)"), ("/sim/state.right_leg_length", "right (truth)"),
                 ("/controller/debug.left_L0_ref", "left set point")],
    "speed (m/s)": [("/sim/state.vx", "vx (truth)"), ("/controller/debug.speed", "speed (controller)"),
                    ("/controller/debug.speed_ref", "set point")],
}


def build() -> str:
    """The layout as Foxglove's JSON."""
    from foxglove import layouts as L  # noqa: PLC0415

    scene = L.ThreeDeePanel(title="robot", config=L.ThreeDeeConfig(
        topics={"/scene": L.BaseRendererSceneUpdateTopicSettings(visible=True)}, follow_tf="world",
        camera_state=L.ThreeDeeCameraState(distance=1.6, phi=70.0, theta_offset=90.0, target=(0.0, 0.0, 0.2),
                                           perspective=True)))
    plots = [L.PlotPanel(title=title, config=L.PlotConfig(
        paths=[L.PlotSeries(value=path, label=label, enabled=True) for path, label in series], show_legend=True))
        for title, series in PLOTS.items()]
    events = L.RawMessagesPanel(title="events", config=L.RawMessagesConfig(topic_path="/scenario/events"))
    column = L.SplitContainer(direction="column",
                              items=[L.SplitItem(content=p) for p in plots] + [L.SplitItem(proportion=0.6, content=events)])
    layout = L.Layout(content=L.SplitContainer(direction="row", items=[
        L.SplitItem(proportion=1.3, content=scene), L.SplitItem(content=column)]))
    return layout.to_json()


if __name__ == "__main__":
    LAYOUT_PATH.write_text(build() + "\n")
    print(LAYOUT_PATH)
