/* The jump (controller/jump.py): squat, thrust, retract, flight, land, as a phase table;
   and the recovery stand from lying (controller/recovery.py): tuck, tilt up. */
#ifndef WL_JUMP_H
#define WL_JUMP_H

#include <stdbool.h>

#include "estimate.h"

typedef enum { WL_JUMP_SQUAT, WL_JUMP_THRUST, WL_JUMP_RETRACT, WL_JUMP_FLIGHT, WL_JUMP_LAND, WL_JUMP_DONE } wl_jump_phase_t;
enum { WL_PHASE_NONE = -1 };

typedef struct {
    bool active;            /* a stance hold is set */
    float axle_offset[2];   /* m, L0 sin(theta) at the thrust's start, per leg */
    float pitch;            /* rad, body pitch at the start */
} wl_stance_hold_t;

typedef struct {
    wl_jump_phase_t phase;
    bool airborne;
    bool has_leg_length;
    float leg_length;       /* m */
    bool has_leg_force;
    float leg_force;        /* N per leg */
    float hip_torque_limit; /* N m */
    wl_stance_hold_t hold;
    bool tuck;              /* in the air, the retraction's stiffer leg PD (in place, RETRACT) */
} wl_jump_cmd_t;

typedef struct {
    float dt;
    double dt_d;
    double elapsed_s;       /* s in this phase (double: the same tick as the Python's sum) */
    wl_jump_phase_t phase;
    int entered;            /* the phase entered this tick, WL_PHASE_NONE for none */
    bool forward;
    wl_lowpass_t stance;    /* the legs' standing push (N) */
    bool has_thrust;
    float carried_n, amplitude_n;
    float mean_length;               /* m, the legs' mean length a tick ago (their rate); NaN before */
    float lengths[2];                /* m, both legs' lengths a tick ago (their shortening); NaN before */
    float mean_angle;                /* rad, the legs' mean angle a tick ago (the run-up's swing); NaN before */
    wl_lowpass_t swing;              /* rad/s, the legs' mean angle rate, low-passed */
    double settled_s;                /* s the swing has stayed within WL_P_JUMP_RUN_UP_SWING_TOL */
    double apex_s;                   /* s from the thrust's end to the predicted top (jump.apex_delay) */
    double air_s;                    /* s since the thrust ended */
    wl_stance_hold_t hold;
} wl_jump_t;

void wl_jump_init(wl_jump_t *j, double period_s);
void wl_jump_observe_stance(wl_jump_t *j, float fn_left, float fn_right);
void wl_jump_start(wl_jump_t *j, bool forward);
bool wl_jump_done(const wl_jump_t *j);
wl_jump_cmd_t wl_jump_step(wl_jump_t *j, const float lengths[2], bool touching, bool steady, const float angles[2],
                           float pitch);
/* (theta, rate) keeping a hip over its start point (jump.hold_leg_angle) */
void wl_hold_leg_angle(float offset, float length, float rate, float *theta, float *dtheta);
/* s from the thrust's end to the top of the jump (jump.apex_delay) */
float wl_jump_apex_delay(float rate_m_s, float carried_n);
/* the thrust's sizing (exposed for the tests) */
float wl_jump_thrust_amplitude(float carried_n, float start_m);

typedef enum { WL_RECOVERY_TUCK, WL_RECOVERY_TILT_UP, WL_RECOVERY_DONE } wl_recovery_phase_t;

typedef struct {
    float dt, pitch_ref;
    double dt_d, elapsed_s;
    wl_recovery_phase_t phase;
    int entered;
} wl_recovery_t;

typedef struct {
    wl_recovery_phase_t phase;
    bool airborne;
    bool has_leg_length, has_pitch;
    float leg_length, pitch;
} wl_recovery_cmd_t;

void wl_recovery_init(wl_recovery_t *r, double period_s);
bool wl_recovery_active(const wl_recovery_t *r);
void wl_recovery_start(wl_recovery_t *r);
void wl_recovery_stop(wl_recovery_t *r);
wl_recovery_cmd_t wl_recovery_step(wl_recovery_t *r, const float lengths[2], float pitch, float target_pitch);

#endif
