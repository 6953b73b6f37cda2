/* Ground support force per leg and the off-ground decision (controller/support.py), and the
   body-on-the-ground check (controller/posture.py). */
#ifndef WL_SUPPORT_H
#define WL_SUPPORT_H

#include <stdbool.h>

#include "estimate.h"
#include "legs.h"

typedef struct {
    wl_derivative_t ddL0, ddtheta;
    wl_lowpass_t fn;
} wl_support_t;

typedef struct {
    int off_ticks, on_ticks, count;
    bool airborne;
} wl_contact_t;

void wl_support_init(wl_support_t *s, float dt);
/* Fn (N, filtered) of one leg from the measured hip torques (N m on the shafts) */
float wl_support_update(wl_support_t *s, const wl_leg_state_t *leg, float front_tau, float rear_tau, int front_sign,
                        int rear_sign, float body_accel_z);
bool wl_support_trusted(const wl_leg_state_t legs[2]);

void wl_contact_init(wl_contact_t *c, float dt);
void wl_contact_reset(wl_contact_t *c);
bool wl_contact_update(wl_contact_t *c, float fn_left, float fn_right, bool trusted);

/* Height (m) of the body box's lowest corner above the ground under the lower wheel;
   side_y, L0, phi0 of each leg (m, m, rad in the five-bar frame) */
float wl_body_clearance(float roll, float pitch, const float side_y[2], const float L0[2], const float phi0[2]);
/* rad: the body's lean onto its side, asin(cos(pitch) sin(roll)); defined at any pitch (the ZYX roll
 * is not at 90 deg of pitch). posture.side_tilt. */
float wl_side_tilt(float roll, float pitch);
/* rad in [0, pi]: the body's up axis from the world's, acos(cos(pitch) cos(roll)). posture.tilt_from_upright. */
float wl_tilt_from_upright(float roll, float pitch);
/* lying where the recovery stand can right it: tilted past fallen_rad up to beyond_rad, side tilt
 * within side_rad. posture.recoverable. */
bool wl_recoverable(float roll, float pitch, float fallen_rad, float beyond_rad, float side_rad);

#endif
