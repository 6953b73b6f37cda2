"""A two-wheeled self-balancing robot for the wheelleg-hil rig, as an installed plug-in.

An inverted pendulum on two wheels: a 2.6 kg body on two M3508 P19 motors with
C620 ESCs (ids 1 and 2), an IMU and the operator's remote, all on CAN1; CAN2
carries only the rig's lockstep frames (SYNC, heartbeat). Modules:

- ``description``: the plant's truth (the CAD numbers), ``robot.xml``/``scene.xml`` its MJCF;
- ``physics``, ``plant``: its MuJoCo world and its emulated devices;
- ``constants``, ``gains`` (written by ``design``), ``controller``, ``__main__``: its controller
  (``python -m wheelleg_balancer``), which imports nothing of the rig but ``wheelleg.dbc``
  and ``wheelleg.controller``'s CAN node, offline detection and attitude, as on the robot;
- ``scenarios``: ``balance`` and ``offline-wheel``; ``robot``: the ``Robot`` the rig loads.
"""
