"""wheelleg-hil: a hardware-in-the-loop rig over CAN for wheel-legged robots.

The package's parts live in the repository's top-level folders and install
under this one name:

- ``wheelleg.dbc``: every frame's byte layout (DBC files) and the codecs built from them;
- ``wheelleg.controller``: the robot's own program, deployable alone (imports nothing else here
  but ``wheelleg.dbc``);
- ``wheelleg.emulators``: the devices on the far side of the bus and the MuJoCo plant;
- ``wheelleg.hil``: the rig: buses, recording, runs and scenarios, analysis, the CLI.
"""
