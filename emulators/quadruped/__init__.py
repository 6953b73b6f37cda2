"""The quadruped, the rig's second robot: its description (truth), MJCF, physics and plant."""
