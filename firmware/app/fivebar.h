/* Five-bar leg kinematics and VMC (controller/fivebar.py; docs/control.md, the five-bar leg).
   Frame: origin at the front hip A, x backward towards the rear hip E at (L5, 0), y down;
   phi1 of link AB, phi4 of ED, phi2 of BC, phi3 of DC; the virtual leg from O = (L5/2, 0)
   to the axle C: length L0 (m), angle phi0 (rad, pi/2 straight down). */
#ifndef WL_FIVEBAR_H
#define WL_FIVEBAR_H

#include <stdbool.h>

typedef struct {
    float phi1, phi4, phi2, phi3;  /* rad */
    float L0, phi0;                /* m, rad */
    float j[2][2];                 /* d(L0, phi0)/d(phi1, phi4): rows L0 (m/rad), phi0 */
} wl_leg_kin_t;

/* Leg pose from the two hip angles (rad); false when they cannot close the loop. */
bool wl_fivebar_forward(float phi1, float phi4, wl_leg_kin_t *k);
/* phi2 (rad) of the pose alone; false as wl_fivebar_forward */
bool wl_fivebar_shin_angle(float phi1, float phi4, float *phi2);
/* (dL0 m/s, dphi0 rad/s) from the hip rates (rad/s) */
void wl_fivebar_velocity(const wl_leg_kin_t *k, float dphi1, float dphi4, float *dL0, float *dphi0);
/* Hip torques (N m on phi1, phi4) for leg push F (N) and torque Tp (N m): J^T [F, -Tp] */
void wl_fivebar_joint_torques(const wl_leg_kin_t *k, float F, float Tp, float *T1, float *T4);
/* (F N, Tp N m) the hip torques exert; false at a singular pose */
bool wl_fivebar_leg_force(const wl_leg_kin_t *k, float T1, float T4, float *F, float *Tp);
/* Hip angles (rad) that put the wheel at (L0 m, phi0 rad); false out of reach */
bool wl_fivebar_inverse(float L0, float phi0, float *phi1, float *phi4);
/* The ground's normal force on the wheel (N), the design document's leg_fn_cal */
float wl_fivebar_support_force(float F, float Tp, float theta, float L0, float dL0, float ddL0, float dtheta,
                               float ddtheta, float body_accel_z);

#endif
