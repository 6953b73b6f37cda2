"""LQR gains of the balancer, written by ``python -m wheelleg_balancer.design`` (do not edit).

u = -K . (x - x_ref, v - v_ref, pitch, pitch rate): the wheels' summed torque (N m) from the axle's
position (m) and speed (m/s) errors and the body's pitch (rad, nose down +) and its rate (rad/s).
"""
K = (-25.102559, -24.9874, -58.233456, -4.201606)
