#include "estimate.h"

#include <math.h>

#include "wl_config.h"
#include "wl_math.h"

static void quat_mul(const float a[4], const float b[4], float out[4]) {
    float w = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
    float x = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
    float y = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
    float z = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
    out[0] = w;
    out[1] = x;
    out[2] = y;
    out[3] = z;
}

static void rotation_vector(const float q[4], float r[3]) {
    float sign = q[0] >= 0.0f ? 1.0f : -1.0f;
    float w = sign * q[0], x = sign * q[1], y = sign * q[2], z = sign * q[3];
    float s = sqrtf(x * x + y * y + z * z);
    if (s < 1e-12f) {
        r[0] = 2.0f * x;
        r[1] = 2.0f * y;
        r[2] = 2.0f * z;
        return;
    }
    float angle = 2.0f * atan2f(s, w);
    r[0] = angle * x / s;
    r[1] = angle * y / s;
    r[2] = angle * z / s;
}

static void quat_exp(const float r[3], float q[4]) {
    float angle = sqrtf(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    if (angle < 1e-12f) {
        q[0] = 1.0f;
        q[1] = 0.5f * r[0];
        q[2] = 0.5f * r[1];
        q[3] = 0.5f * r[2];
        return;
    }
    float s = sinf(0.5f * angle) / angle;
    q[0] = cosf(0.5f * angle);
    q[1] = r[0] * s;
    q[2] = r[1] * s;
    q[3] = r[2] * s;
}

void wl_gyro_bias_init(wl_gyro_bias_t *g, float dt, float omega_n, float limit) {
    g->dt = dt;
    g->limit = limit;
    g->kp = 2.0f * omega_n;
    g->ki = omega_n * omega_n;
    g->bias[0] = g->bias[1] = g->bias[2] = 0.0f;
    g->has_quat = false;
}

void wl_gyro_bias_update(wl_gyro_bias_t *g, const float quat[4], const float gyro[3]) {
    if (!g->has_quat) {
        for (int i = 0; i < 4; i++) g->quat[i] = quat[i];
        g->has_quat = true;
        return;
    }
    float conj[4] = {g->quat[0], -g->quat[1], -g->quat[2], -g->quat[3]};
    float rel[4], e[3], rate_dt[3], step[4], q[4];
    quat_mul(conj, quat, rel);
    rotation_vector(rel, e);
    for (int i = 0; i < 3; i++) {
        g->bias[i] = wl_clamp(g->bias[i] - g->ki * e[i] * g->dt, g->limit);
        rate_dt[i] = (gyro[i] - g->bias[i] + g->kp * e[i]) * g->dt;
    }
    quat_exp(rate_dt, step);
    quat_mul(g->quat, step, q);
    float norm = sqrtf(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (int i = 0; i < 4; i++) g->quat[i] = q[i] / norm;
}

float wl_forward_accel(const float q[4], const float f[3]) {
    float w = q[0], x = q[1], y = q[2], z = q[3];
    float ax = (1 - 2 * (y * y + z * z)) * f[0] + 2 * (x * y - w * z) * f[1] + 2 * (x * z + w * y) * f[2];
    float ay = 2 * (x * y + w * z) * f[0] + (1 - 2 * (x * x + z * z)) * f[1] + 2 * (y * z - w * x) * f[2];
    float yaw = atan2f(2 * (w * z + x * y), 1 - 2 * (y * y + z * z));
    return ax * cosf(yaw) + ay * sinf(yaw);
}

float wl_vertical_accel(const float q[4], const float f[3]) {
    float w = q[0], x = q[1], y = q[2], z = q[3];
    float r20 = 2 * (x * z - w * y), r21 = 2 * (y * z + w * x), r22 = 1 - 2 * (x * x + y * y);
    return r20 * f[0] + r21 * f[1] + r22 * f[2] - WL_C_GRAVITY;
}

void wl_slip_init(wl_slip_t *s, float dt, float gain, float on, float window, float grip) {
    s->dt = dt;
    s->gain = gain;
    s->on = on;
    s->window = window;
    s->grip = grip;
    s->speed = 0.0f;
    s->slipping = false;
    s->win_elapsed = 0.0;
    s->win_imu_change = s->win_wheels_start = 0.0f;
}

static void watch_grip(wl_slip_t *s, float accel, float wheels) {
    double elapsed = s->win_elapsed + (double)s->dt;
    float imu_change = s->win_imu_change + accel * s->dt;
    if (fabsf(wheels - s->speed) < s->grip) {
        s->slipping = false;
    } else if (elapsed < (double)s->window) {
        s->win_elapsed = elapsed;
        s->win_imu_change = imu_change;
    } else if (fabsf((wheels - s->win_wheels_start) - imu_change) < s->grip) {
        s->slipping = false;
        s->speed = wheels;
    } else {
        s->win_elapsed = 0.0;
        s->win_imu_change = 0.0f;
        s->win_wheels_start = wheels;
    }
}

bool wl_slip_update(wl_slip_t *s, float accel, float wheels) {
    s->speed += accel * s->dt;
    if (s->slipping) {
        watch_grip(s, accel, wheels);
    } else if (fabsf(wheels - s->speed) > s->on) {
        s->slipping = true;
        s->win_elapsed = 0.0;
        s->win_imu_change = 0.0f;
        s->win_wheels_start = wheels;
    }
    if (!s->slipping) s->speed += s->gain * (wheels - s->speed) * s->dt;
    return s->slipping;
}

void wl_balance_point_init(wl_balance_point_t *b, float dt, float tau_learn, float learn_s, float tau, float still,
                           float settle) {
    b->dt = dt;
    b->tau_learn = tau_learn;
    b->learn_s = learn_s;
    b->tau = tau;
    b->still = still;
    b->settle = settle;
    b->blocked_s = b->hold_torque = 0.0f;
    b->learn_ticks = lround((double)learn_s / (double)dt);  /* a whole count: ends on the Python's tick */
    b->learnt_ticks = 0;
}

float wl_balance_point_update(wl_balance_point_t *b, float lean_hold_torque, float speed, bool standing) {
    if (fabsf(speed) > b->still) b->blocked_s = b->settle;
    b->blocked_s = wl_maxf(0.0f, b->blocked_s - b->dt);
    float tau = b->learnt_ticks < b->learn_ticks ? b->tau_learn : b->tau;
    /* the start-up window runs on once begun (controller/estimate.py BalancePointObserver) */
    if ((standing || b->learnt_ticks > 0) && b->learnt_ticks < b->learn_ticks) b->learnt_ticks++;
    if (!standing || b->blocked_s > 0.0f) return b->hold_torque;
    b->hold_torque += (lean_hold_torque - b->hold_torque) * wl_minf(1.0f, b->dt / tau);
    return b->hold_torque;
}

void wl_lowpass_init(wl_lowpass_t *f, float tau, float dt) {
    f->alpha = dt / (tau + dt);
    f->value = 0.0f;
    f->has_value = false;
}

float wl_lowpass(wl_lowpass_t *f, float x) {
    f->value = f->has_value ? f->value + f->alpha * (x - f->value) : x;
    f->has_value = true;
    return f->value;
}

void wl_derivative_init(wl_derivative_t *d, float tau, float dt) {
    d->dt = dt;
    d->last = 0.0f;
    d->has_last = false;
    wl_lowpass_init(&d->filter, tau, dt);
}

float wl_derivative(wl_derivative_t *d, float x) {
    float raw = d->has_last ? (x - d->last) / d->dt : 0.0f;
    d->last = x;
    d->has_last = true;
    return wl_lowpass(&d->filter, raw);
}
