/* K(L0): the LQR gains at the present leg length from the fitted table (controller/lqr.py).
   u = -K (s - s_ref), s = [theta, dtheta, x, dx, phi, dphi, ix, T_prev, Tp_prev], u = [T, Tp]. */
#ifndef WL_LQR_H
#define WL_LQR_H

#define WL_LQR_INPUTS 2
#define WL_LQR_STATES 9
enum { WL_S_THETA, WL_S_DTHETA, WL_S_X, WL_S_DX, WL_S_PHI, WL_S_DPHI, WL_S_IX, WL_S_T_PREV, WL_S_TP_PREV };

/* the generated table (lqr_gains.c, python -m wheelleg.controller.design.lqr) */
extern const float WL_LQR_DT, WL_LQR_L0_MIN, WL_LQR_L0_MAX;
extern const float WL_LQR_COEFFS[WL_LQR_INPUTS][WL_LQR_STATES][4];
extern const float WL_LQR_ARM[4];

/* K at leg length L0 (m), clamped to the fit's range (a NaN L0 gives the shortest). */
void wl_lqr_gains(float L0, float k[WL_LQR_INPUTS][WL_LQR_STATES]);
/* sum of gains[i] * states[i] over n, left to right */
float wl_lqr_dot(const float *gains, const float *states, int n);
/* Leg angle (rad) of the balance point for hold torque (N m per leg) at L0 (m), within +-limit */
/* N m per leg holding the body when the legs balance leaning at theta (rad): the inverse of
 * wl_lqr_balance_lean, -ARM(L0) weight_ratio sin(theta) */
float wl_lqr_lean_hold_torque(float theta, float L0, float weight_ratio);
float wl_lqr_balance_lean(float hold_torque, float L0, float limit, float weight_ratio);

#endif
