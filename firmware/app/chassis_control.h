/* The chassis controller (controller/chassis.py): LQR on the wheel-legged pendulum over the
   leg length, VMC legs, leg-length PID with gravity feed-forward, roll levelling and leaning,
   yaw, split legs, the trim and the estimators; in the air the leg and pitch holds. */
#ifndef WL_CHASSIS_CONTROL_H
#define WL_CHASSIS_CONTROL_H

#include <stdbool.h>

#include "can_rx.h"
#include "estimate.h"
#include "jump.h"
#include "legs.h"

typedef struct {
    float speed, yaw_rate, leg_length, pitch, roll;  /* m/s, rad/s, m, rad (nose down +), rad */
    bool airborne, air_leg_hold, air_pitch_hold, trim;
    bool air_tuck;  /* in the air, pull the legs in with the retraction's PD (a jump's RETRACT) */
    bool has_leg_force;
    float leg_force;         /* N per leg (jump thrust) */
    float hip_torque_limit;  /* N m */
    wl_stance_hold_t stance_hold;
} wl_chassis_cmd_t;

typedef struct {
    wl_attitude_t att;
    wl_leg_state_t legs[2];
    bool valid;  /* the IMU was heard and both legs closed their loops */
} wl_sensed_t;

typedef struct {
    float hip_torque[WL_N_JOINTS];   /* N m, shaft, WL_JOINT_TABLE order */
    float wheel_torque[WL_N_WHEELS]; /* N m, output, WL_WHEEL_TABLE order */
    float wheel_t[2], tp[2];         /* N m per leg: T and Tp as asked */
    float speed;                     /* m/s */
} wl_chassis_out_t;

typedef struct {
    float dt;
    double dt_d;                     /* s, the period in double for the trim's timer */
    float x, x_ref, speed_ref, accel_ref, yaw_ref, roll_offset, lean, x_integral;
    float yaw_rate_ref;              /* rad/s, the commanded turn rate eased in and out (YAW_ACCEL_LIMIT) */
    double trim_hold_s;              /* s (double: the same tick as the Python's sum) */
    float takeoff_speed, takeoff_error;
    float speed_prev, accel;         /* m/s a period ago, m/s^2 lagged: the balance point's acceleration */
    bool in_air;
    wl_travel_t travel;
    float blocked;                   /* +1/-1: held back driving forward/backward (a wall); 0: free */
    double unblock_s;                /* s the command has not asked the blocked way (double: the Python's sum) */
    float leg_ref[2], leg_integral[2];
    float u_prev[2][2];              /* (T, Tp) per leg, sent last period */
    float balance_theta;
    float dither_sign;               /* +1/-1, flipped every tick on the ground: the hips' dither */
    float dither_size;               /* N m, its amplitude, slewed on and off */
    float speed_to_trim_s;
    wl_gyro_bias_t gyro;
    wl_slip_t slip;
    wl_balance_point_t balance_point;
} wl_chassis_t;

void wl_chassis_init(wl_chassis_t *c, double period_s);
wl_chassis_cmd_t wl_chassis_default_cmd(void);
/* Every tick: the estimators, and what the buses say now (sensed->valid false before the IMU) */
void wl_chassis_observe(wl_chassis_t *c, const wl_bus_state_t *bus, wl_sensed_t *sensed);
wl_attitude_t wl_chassis_attitude(const wl_chassis_t *c, const wl_bus_state_t *bus);
void wl_chassis_sense(const wl_chassis_t *c, const wl_bus_state_t *bus, wl_sensed_t *sensed);
void wl_chassis_reset(wl_chassis_t *c, const wl_bus_state_t *bus);
void wl_chassis_step(wl_chassis_t *c, const wl_chassis_cmd_t *cmd, const wl_sensed_t *sensed, wl_chassis_out_t *out);
void wl_chassis_touchdown(wl_chassis_t *c, const wl_bus_state_t *bus, bool keep_spot);
void wl_chassis_follow_position(wl_chassis_t *c);

#endif
