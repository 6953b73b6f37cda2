/* The virtual legs and the body as the chassis sees them, their set points, and the speed
   set point's S-curve (controller/legs.py, attitude.py, motion.py): pure functions. */
#ifndef WL_LEGS_H
#define WL_LEGS_H

#include <stdbool.h>

#include "can_rx.h"
#include "fivebar.h"

enum { WL_LEFT = 0, WL_RIGHT = 1, WL_N_LEGS = 2 };

typedef struct {
    float roll, pitch, yaw;  /* rad, ZYX; pitch > 0 nose down */
    float wx, wy, wz;        /* rad/s body rates, gyro bias out */
} wl_attitude_t;

typedef struct {
    wl_leg_kin_t kin;
    float L0, dL0, theta, dtheta;  /* m, m/s, rad (wheel behind hip positive), rad/s */
    float wheel_speed;             /* m/s, axle speed along the ground */
    float dphi1, dphi4;            /* rad/s, the front and rear hip joints' rates (relative to the body) */
} wl_leg_state_t;

typedef enum { WL_TRAVEL_STANDING, WL_TRAVEL_SPEEDING_UP, WL_TRAVEL_CRUISING, WL_TRAVEL_BRAKING } wl_travel_t;

wl_attitude_t wl_attitude(const wl_imu_t *imu, const float bias[3]);
/* Leg state of leg (WL_LEFT/WL_RIGHT); false when its hip angles do not close the loop */
bool wl_leg_state(const wl_bus_state_t *bus, int leg, const wl_attitude_t *att, wl_leg_state_t *out);
float wl_mean_speed(const wl_leg_state_t legs[2]);
float wl_legs_under_body(const wl_leg_state_t legs[2]);
float wl_turn_lean(float speed, float yaw_rate);
float wl_roll_leg_difference(float roll_set_point, float level_offset);
void wl_leg_targets(float length, float difference, float targets[2]);
/* The S-curve one period dt on: speed (m/s) and accel (m/s^2) updated towards target */
/* m/s^3 the speed set point eases off at onto target (m/s): slower near the top speed (params.py) */
float wl_ease_jerk(float target);
void wl_speed_set_point(float *speed, float *accel, float target, float dt);
wl_travel_t wl_travel_phase(float speed, float accel);

#endif
