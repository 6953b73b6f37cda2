"""The quadruped's controller: a program of its own beside the wheel-legged robot's.

A 12-motor quadruped (legs FR, FL, RR, RL; per leg abduction, thigh, calf), all
CyberGears in MIT mode on two CAN buses, an IMU at the body's centre and a
remote (``QuadOperator``). Run as ``python -m wheelleg.controller.quadruped``;
like ``wheelleg.controller`` it imports no part of the rig and is deployed
alone. docs/quadruped-control.md describes the laws; the modules:

- ``constants``: what the controller believes about the robot (geometry, mass,
  wiring), each number with its source; ``params``: the tuning choices.
- ``kinematics``: one leg's forward/inverse kinematics, Jacobian and the
  joint torques of a foot force (the sign trap); ``legs``: the four legs at
  once and the joint commands; ``rotations``, ``sensed``: body frames and
  what a tick has measured.
- ``modes``: the mode machine as a table; ``stance`` and ``balance``: foot
  positions by IK and the force distribution, the balance stand; ``getup``:
  the stand-up and recovery trajectories; ``gait``: the trot.
- ``state``: frames in -> what the controller knows; ``node``: the tick (MIT
  frames and heartbeats out) and the node the rig or the robot runs;
  ``telemetry``: the debug record.
"""
