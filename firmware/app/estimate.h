/* Estimators (controller/estimate.py): gyro bias against the IMU's orientation, wheel slip
   against its acceleration, the balance point's hold torque; and the first-order filters
   of controller/support.py. */
#ifndef WL_ESTIMATE_H
#define WL_ESTIMATE_H

#include <stdbool.h>

typedef struct {
    float dt, kp, ki, limit;
    float bias[3];  /* rad/s body frame */
    float quat[4];  /* the propagated orientation (w, x, y, z) */
    bool has_quat;
} wl_gyro_bias_t;

typedef struct {
    float dt, gain, on, window, grip;
    float speed;  /* m/s, the IMU's body speed */
    bool slipping;
    double win_elapsed;  /* s into the grip window (double: the same tick as the Python's sum) */
    float win_imu_change, win_wheels_start;
} wl_slip_t;

typedef struct {
    float dt, tau_learn, learn_s, tau, still, settle;
    float blocked_s, hold_torque;
    long learn_ticks, learnt_ticks;  /* the start-up window, counted from the first standing tick */
} wl_balance_point_t;

typedef struct {
    float alpha, value;
    bool has_value;
} wl_lowpass_t;

typedef struct {
    float dt, last;
    bool has_last;
    wl_lowpass_t filter;
} wl_derivative_t;

void wl_gyro_bias_init(wl_gyro_bias_t *g, float dt, float omega_n, float limit);
void wl_gyro_bias_update(wl_gyro_bias_t *g, const float quat[4], const float gyro[3]);
/* World-horizontal acceleration (m/s^2) along the heading, gravity removed */
float wl_forward_accel(const float quat[4], const float specific_force[3]);
/* World-vertical acceleration (m/s^2, up positive, 0 at rest) */
float wl_vertical_accel(const float quat[4], const float specific_force[3]);

void wl_slip_init(wl_slip_t *s, float dt, float gain, float on, float window, float grip);
bool wl_slip_update(wl_slip_t *s, float accel, float wheels_body_speed);

void wl_balance_point_init(wl_balance_point_t *b, float dt, float tau_learn, float learn_s, float tau, float still,
                           float settle);
float wl_balance_point_update(wl_balance_point_t *b, float lean_hold_torque, float speed, bool standing);

void wl_lowpass_init(wl_lowpass_t *f, float tau, float dt);
float wl_lowpass(wl_lowpass_t *f, float x);
void wl_derivative_init(wl_derivative_t *d, float tau, float dt);
float wl_derivative(wl_derivative_t *d, float x);

#endif
