"""Watching a run: the pose in the trace, offscreen video, MuJoCo's viewer, the Foxglove live server, report.html."""
