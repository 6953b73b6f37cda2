/* Bounds and angles on float32, the control math's small helpers (controller/bounds.py,
   legs.wrap, legs.unwind): the same comparisons in the same order as the Python program. */
#ifndef WL_MATH_H
#define WL_MATH_H

#include <math.h>

#define WL_PI 3.14159265358979323846f

/* value within +-limit (NaN gives limit, as max(-limit, min(limit, value))) */
static inline float wl_clamp(float value, float limit) {
    float low = value < limit ? value : limit;
    return low > -limit ? low : -limit;
}

/* value within [low, high] (NaN stays NaN) */
static inline float wl_within(float value, float low, float high) {
    value = low > value ? low : value;
    return high < value ? high : value;
}

static inline float wl_minf(float a, float b) { return b < a ? b : a; }
static inline float wl_maxf(float a, float b) { return b > a ? b : a; }

/* angle (rad) brought into [-pi, pi) (Python's floored modulo) */
static inline float wl_wrap(float angle) {
    const float two_pi = 2.0f * WL_PI;
    float shifted = angle + WL_PI;
    float m = shifted - two_pi * floorf(shifted / two_pi);
    if (m >= two_pi) m -= two_pi;
    return m - WL_PI;
}

/* integral moved by step only towards zero, never past it */
static inline float wl_unwind(float integral, float step) {
    if (integral * step >= 0.0f) return integral;
    float moved = integral + step;
    return moved * integral > 0.0f ? moved : 0.0f;
}

#endif
