"""Dry (Coulomb) friction of the geared joints, as the controller compensates it: pure functions.

A geared hip's gearbox and seals hold a torque of about its dry friction whatever
the motor asks (docs/control.md, friction and disturbances). The controller adds
that torque back in the direction the joint turns or, at rest, is asked to turn (a
Coulomb feed-forward), fading linearly to zero about standstill and about no torque
asked, so a joint at rest and asked nothing is not kicked back and forth.
"""
from __future__ import annotations

from wheelleg.controller.bounds import clamp


def coulomb_feed_forward(speed_rad_s: float, move_torque_nm: float, friction_nm: float,
                         speed_band_rad_s: float, torque_band_nm: float) -> float:
    """Torque (N m) that cancels ``friction_nm`` of dry friction on a joint turning at
    ``speed_rad_s`` and asked ``move_torque_nm`` beyond what holds it still.

    Friction opposes the motion: turning faster than ``speed_band_rad_s`` the full
    friction goes the way the joint turns; slower, the rest of it (1 - |speed| / band)
    goes the way it is asked to turn (full past ``torque_band_nm``), so at rest it breaks
    the stiction the way the controller wants the joint to go. Continuous, within
    +-``friction_nm``.
    """
    turning = clamp(speed_rad_s / speed_band_rad_s, 1.0)
    asked = clamp(move_torque_nm / torque_band_nm, 1.0)
    return friction_nm * (turning + (1.0 - abs(turning)) * asked)
