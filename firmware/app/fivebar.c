#include "fivebar.h"

#include <math.h>

#include "wl_config.h"

#define TWO_PI_F 6.28318530717958647692f
#define CLOSURE_TOL 1e-9f

/* angle mapped to (-pi, pi] */
static float wrap_closed(float angle) {
    return angle - TWO_PI_F * ceilf((angle - 3.14159265358979323846f) / TWO_PI_F);
}

static bool knees_and_phi2(float phi1, float phi4, float *xb, float *yb, float *xd, float *yd, float *phi2) {
    if (!isfinite(phi1) || !isfinite(phi4)) return false;
    *xb = WL_C_L1 * cosf(phi1);
    *yb = WL_C_L1 * sinf(phi1);
    *xd = WL_C_L5 + WL_C_L4 * cosf(phi4);
    *yd = WL_C_L4 * sinf(phi4);
    float bd_x = *xd - *xb, bd_y = *yd - *yb;
    float a0 = 2.0f * WL_C_L2 * bd_x, b0 = 2.0f * WL_C_L2 * bd_y;
    float bd_sq = bd_x * bd_x + bd_y * bd_y;
    float c0 = WL_C_L2 * WL_C_L2 + bd_sq - WL_C_L3 * WL_C_L3;
    float ab_sq = a0 * a0 + b0 * b0;
    float disc = ab_sq - c0 * c0;
    if (disc < -CLOSURE_TOL * ab_sq || bd_sq == 0.0f) return false;
    float root = sqrtf(disc > 0.0f ? disc : 0.0f);
    *phi2 = wrap_closed(2.0f * atan2f(b0 + root, a0 + c0));
    return true;
}

bool wl_fivebar_shin_angle(float phi1, float phi4, float *phi2) {
    float xb, yb, xd, yd;
    return knees_and_phi2(phi1, phi4, &xb, &yb, &xd, &yd, phi2);
}

bool wl_fivebar_forward(float phi1, float phi4, wl_leg_kin_t *k) {
    float xb, yb, xd, yd, phi2;
    if (!knees_and_phi2(phi1, phi4, &xb, &yb, &xd, &yd, &phi2)) return false;
    float xc = xb + WL_C_L2 * cosf(phi2), yc = yb + WL_C_L2 * sinf(phi2);
    float phi3 = atan2f(yc - yd, xc - xd);
    float dx = xc - 0.5f * WL_C_L5;
    float L0 = hypotf(dx, yc), phi0 = atan2f(yc, dx);
    k->phi1 = phi1;
    k->phi4 = phi4;
    k->phi2 = phi2;
    k->phi3 = phi3;
    k->L0 = L0;
    k->phi0 = phi0;
    /* closed-form Jacobian from the loop closure (fivebar._jacobian) */
    float s32 = sinf(phi3 - phi2);
    float a = WL_C_L1 * sinf(phi1 - phi2) / s32;
    float b = WL_C_L4 * sinf(phi3 - phi4) / s32;
    k->j[0][0] = a * sinf(phi0 - phi3);
    k->j[0][1] = b * sinf(phi0 - phi2);
    k->j[1][0] = a * cosf(phi0 - phi3) / L0;
    k->j[1][1] = b * cosf(phi0 - phi2) / L0;
    return true;
}

void wl_fivebar_velocity(const wl_leg_kin_t *k, float dphi1, float dphi4, float *dL0, float *dphi0) {
    *dL0 = k->j[0][0] * dphi1 + k->j[0][1] * dphi4;
    *dphi0 = k->j[1][0] * dphi1 + k->j[1][1] * dphi4;
}

void wl_fivebar_joint_torques(const wl_leg_kin_t *k, float F, float Tp, float *T1, float *T4) {
    *T1 = k->j[0][0] * F - k->j[1][0] * Tp;
    *T4 = k->j[0][1] * F - k->j[1][1] * Tp;
}

bool wl_fivebar_leg_force(const wl_leg_kin_t *k, float T1, float T4, float *F, float *Tp) {
    float det = k->j[0][0] * k->j[1][1] - k->j[1][0] * k->j[0][1];
    if (!(fabsf(det) >= 1e-12f)) return false;
    *F = (k->j[1][1] * T1 - k->j[1][0] * T4) / det;
    *Tp = -((k->j[0][0] * T4 - k->j[0][1] * T1) / det);
    return true;
}

static bool hip_angle(float dx, float dy, float thigh, float shin, float side, float *angle) {
    float reach = hypotf(dx, dy);
    float cos_knee = reach != 0.0f ? (thigh * thigh + reach * reach - shin * shin) / (2.0f * thigh * reach) : 2.0f;
    if (!(cos_knee >= -1.0f && cos_knee <= 1.0f)) return false;
    *angle = atan2f(dy, dx) + side * acosf(cos_knee);
    return true;
}

bool wl_fivebar_inverse(float L0, float phi0, float *phi1, float *phi4) {
    float xc = 0.5f * WL_C_L5 + L0 * cosf(phi0), yc = L0 * sinf(phi0);
    return hip_angle(xc, yc, WL_C_L1, WL_C_L2, 1.0f, phi1) && hip_angle(xc - WL_C_L5, yc, WL_C_L4, WL_C_L3, -1.0f, phi4);
}

float wl_fivebar_support_force(float F, float Tp, float theta, float L0, float dL0, float ddL0, float dtheta,
                               float ddtheta, float body_accel_z) {
    float s = sinf(theta), c = cosf(theta);
    float push = F * c - Tp * s / L0;
    float wheel_accel_z = body_accel_z - ddL0 * c + 2.0f * dL0 * dtheta * s + L0 * ddtheta * s + L0 * dtheta * dtheta * c;
    return push + WL_MASS_AT_AXLE * (WL_C_GRAVITY + wheel_accel_z);
}
