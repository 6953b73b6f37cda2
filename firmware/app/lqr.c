#include "lqr.h"

#include <math.h>

#include "wl_math.h"

static float cubic(const float c[4], float x) {
    return ((c[0] * x + c[1]) * x + c[2]) * x + c[3];
}

void wl_lqr_gains(float L0, float k[WL_LQR_INPUTS][WL_LQR_STATES]) {
    float length = isfinite(L0) ? wl_within(L0, WL_LQR_L0_MIN, WL_LQR_L0_MAX) : WL_LQR_L0_MIN;
    for (int i = 0; i < WL_LQR_INPUTS; i++) {
        for (int j = 0; j < WL_LQR_STATES; j++) k[i][j] = cubic(WL_LQR_COEFFS[i][j], length);
    }
}

float wl_lqr_dot(const float *gains, const float *states, int n) {
    float sum = 0.0f;
    for (int i = 0; i < n; i++) sum += gains[i] * states[i];
    return sum;
}

float wl_lqr_lean_hold_torque(float theta, float L0, float weight_ratio) {
    float length = wl_within(L0, WL_LQR_L0_MIN, WL_LQR_L0_MAX);
    return -cubic(WL_LQR_ARM, length) * weight_ratio * sinf(theta);
}

float wl_lqr_balance_lean(float hold_torque, float L0, float limit, float weight_ratio) {
    float length = wl_within(L0, WL_LQR_L0_MIN, WL_LQR_L0_MAX);
    float arm = cubic(WL_LQR_ARM, length) * weight_ratio;
    return wl_clamp(-asinf(wl_clamp(hold_torque / arm, 1.0f)), limit);
}
