#include "support.h"

#include <math.h>

#include "fivebar.h"
#include "wl_config.h"
#include "wl_math.h"

void wl_support_init(wl_support_t *s, float dt) {
    wl_derivative_init(&s->ddL0, WL_P_FN_DERIVATIVE_TAU, dt);
    wl_derivative_init(&s->ddtheta, WL_P_FN_DERIVATIVE_TAU, dt);
    wl_lowpass_init(&s->fn, WL_P_FN_FILTER_TAU, dt);
}

float wl_support_update(wl_support_t *s, const wl_leg_state_t *leg, float front_tau, float rear_tau, int front_sign,
                        int rear_sign, float body_accel_z) {
    float F = 0.0f, Tp = 0.0f;
    if (!wl_fivebar_leg_force(&leg->kin, (float)front_sign * front_tau, (float)rear_sign * rear_tau, &F, &Tp)) {
        F = Tp = 0.0f;  /* no unique answer at the singular stretch: "no push" */
    }
    float ddL0 = wl_derivative(&s->ddL0, leg->dL0);
    float ddtheta = wl_derivative(&s->ddtheta, leg->dtheta);
    float raw = wl_fivebar_support_force(F, Tp, leg->theta, leg->L0, leg->dL0, ddL0, leg->dtheta, ddtheta,
                                         body_accel_z);
    if (!isfinite(raw) || !(leg->L0 > 0.0f)) raw = s->fn.has_value ? s->fn.value : 0.0f;
    return wl_lowpass(&s->fn, raw);
}

bool wl_support_trusted(const wl_leg_state_t legs[2]) {
    return fabsf(legs[0].theta) < WL_P_FN_TRUST_THETA && fabsf(legs[1].theta) < WL_P_FN_TRUST_THETA;
}

static int ticks_of(float seconds, float dt) {
    int n = (int)lrintf(seconds / dt);
    return n < 1 ? 1 : n;
}

void wl_contact_init(wl_contact_t *c, float dt) {
    c->off_ticks = ticks_of(WL_P_OFF_GROUND_DEBOUNCE, dt);
    c->on_ticks = ticks_of(WL_P_TOUCHDOWN_DEBOUNCE, dt);
    wl_contact_reset(c);
}

void wl_contact_reset(wl_contact_t *c) {
    c->airborne = false;
    c->count = 0;
}

bool wl_contact_update(wl_contact_t *c, float fn_left, float fn_right, bool trusted) {
    bool changing;
    int needed;
    if (c->airborne) {
        changing = wl_maxf(fn_left, fn_right) > WL_P_FN_ON;
        needed = c->on_ticks;
    } else {
        changing = trusted && wl_maxf(fn_left, fn_right) < WL_P_FN_OFF;
        needed = c->off_ticks;
    }
    c->count = changing ? c->count + 1 : 0;
    if (c->count >= needed) {
        c->airborne = !c->airborne;
        c->count = 0;
    }
    return c->airborne;
}

float wl_side_tilt(float roll, float pitch) {
    return asinf(wl_clamp(cosf(pitch) * sinf(roll), 1.0f));
}

float wl_tilt_from_upright(float roll, float pitch) {
    return acosf(wl_clamp(cosf(pitch) * cosf(roll), 1.0f));
}

bool wl_recoverable(float roll, float pitch, float fallen_rad, float beyond_rad, float side_rad) {
    float tilt = wl_tilt_from_upright(roll, pitch);
    return tilt > fallen_rad && tilt <= beyond_rad && fabsf(wl_side_tilt(roll, pitch)) < side_rad;
}

float wl_body_clearance(float roll, float pitch, const float side_y[2], const float L0[2], const float phi0[2]) {
    float row[3] = {-sinf(pitch), cosf(pitch) * sinf(roll), cosf(pitch) * cosf(roll)};
    float ground = INFINITY;
    for (int i = 0; i < 2; i++) {
        float axle[3] = {-L0[i] * cosf(phi0[i]), side_y[i], -WL_C_BODY_COM_ABOVE_HIP - L0[i] * sinf(phi0[i])};
        float h = row[0] * axle[0] + row[1] * axle[1] + row[2] * axle[2];
        ground = wl_minf(ground, h);
    }
    ground -= WL_C_WHEEL_RADIUS;
    const float half[3] = {0.5f * WL_C_BODY_SIZE_0, 0.5f * WL_C_BODY_SIZE_1, 0.5f * WL_C_BODY_SIZE_2};
    float lowest = INFINITY;
    for (int corner = 0; corner < 8; corner++) {
        float p[3] = {(corner & 4) ? half[0] : -half[0], (corner & 2) ? half[1] : -half[1],
                      (corner & 1) ? half[2] : -half[2]};
        lowest = wl_minf(lowest, row[0] * p[0] + row[1] * p[1] + row[2] * p[2]);
    }
    return lowest - ground;
}
