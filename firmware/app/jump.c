#include "jump.h"

#include <math.h>

#include "fivebar.h"
#include "wl_config.h"
#include "wl_math.h"

#define STROKE_STEPS 26
static float STROKE[STROKE_STEPS];  /* m, stroke points */
static float LIMITS[STROKE_STEPS];  /* N, push_limit at each */
static bool tables_made;

static float hermite(float length) {
    float s = (length - WL_P_JUMP_SQUAT_LENGTH) / (WL_P_JUMP_THRUST_END_LENGTH - WL_P_JUMP_SQUAT_LENGTH);
    s = wl_minf(wl_maxf(s, 0.0f), 1.0f);
    return 1.0f - 3.0f * s * s + 2.0f * s * s * s;
}

static float push_limit(float length) {
    float phi1, phi4, t1 = 1.0f, t4 = 1.0f;
    wl_leg_kin_t k;
    if (wl_fivebar_inverse(length, WL_PI / 2, &phi1, &phi4) && wl_fivebar_forward(phi1, phi4, &k)) {
        wl_fivebar_joint_torques(&k, 1.0f, 0.0f, &t1, &t4);
    }
    return WL_P_JUMP_THRUST_TORQUE_SHARE * WL_P_JUMP_HIP_TORQUE_LIMIT / wl_maxf(fabsf(t1), fabsf(t4));
}

static void make_tables(void) {
    if (tables_made) return;
    for (int i = 0; i < STROKE_STEPS; i++) {
        STROKE[i] = WL_P_JUMP_SQUAT_LENGTH
                    + (WL_P_JUMP_THRUST_END_LENGTH - WL_P_JUMP_SQUAT_LENGTH) * (float)i / (float)(STROKE_STEPS - 1);
        LIMITS[i] = push_limit(STROKE[i]);
    }
    tables_made = true;
}

static float push_limit_at(float length) {
    if (length <= STROKE[0]) return LIMITS[0];
    if (length >= STROKE[STROKE_STEPS - 1]) return LIMITS[STROKE_STEPS - 1];
    float step = STROKE[1] - STROKE[0];
    int i = (int)((length - STROKE[0]) / step);
    if (i > STROKE_STEPS - 2) i = STROKE_STEPS - 2;
    float w = (length - STROKE[i]) / step;
    return LIMITS[i] + w * (LIMITS[i + 1] - LIMITS[i]);
}

static float thrust_force(float carried, float amplitude, float length) {
    return wl_minf(carried + amplitude * hermite(length), push_limit_at(length));
}

/* the lengthening rate (m/s) the push gives the legs by length (takeoff_work's model) */
static float planned_rate(float carried, float amplitude, float length);

/* thrust_force plus JUMP_RATE_KP per m/s the legs lengthen slower than planned, within the limit */
static float tracked_thrust_force(float carried, float amplitude, float length, float rate) {
    float behind = wl_maxf(planned_rate(carried, amplitude, length) - rate, 0.0f);
    return wl_minf(thrust_force(carried, amplitude, length) + WL_P_JUMP_RATE_KP * behind, push_limit_at(length));
}

static float takeoff_work(float carried) {
    float m = wl_maxf(carried, 1e-3f) / WL_C_GRAVITY;
    float v_after = sqrtf(2.0f * WL_C_GRAVITY * WL_P_JUMP_RISE);
    float v_end = v_after * (m + WL_MASS_AT_AXLE) / m;
    return 0.5f * m * v_end * v_end;
}

static float stroke_work(float carried, float amplitude, float start) {
    float work = 0.0f;
    for (int i = 0; i + 1 < STROKE_STEPS; i++) {
        float lo = wl_maxf(STROKE[i], start), hi = STROKE[i + 1];
        if (hi > lo) work += (thrust_force(carried, amplitude, 0.5f * (lo + hi)) - carried) * (hi - lo);
    }
    return work;
}

static float planned_rate(float carried, float amplitude, float length) {
    float work = stroke_work(carried, amplitude, WL_P_JUMP_SQUAT_DONE_LENGTH) - stroke_work(carried, amplitude, length);
    return sqrtf(2.0f * wl_maxf(work, 0.0f) * WL_C_GRAVITY / wl_maxf(carried, 1e-3f));
}

float wl_jump_thrust_amplitude(float carried, float start) {
    make_tables();
    float target = takeoff_work(carried);
    float lo = 0.0f, hi = WL_P_JUMP_AMPLITUDE_MAX;
    if (stroke_work(carried, hi, start) <= target) return hi;
    for (int i = 0; i < 30; i++) {
        float mid = 0.5f * (lo + hi);
        if (stroke_work(carried, mid, start) < target) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return hi;
}

void wl_hold_leg_angle(float offset, float length, float rate, float *theta, float *dtheta) {
    float sine = wl_minf(wl_maxf(offset / length, -WL_P_JUMP_HOLD_SINE_LIMIT), WL_P_JUMP_HOLD_SINE_LIMIT);
    *theta = asinf(sine);
    *dtheta = -sine * rate / (length * cosf(*theta));
}

void wl_jump_init(wl_jump_t *j, double period_s) {
    make_tables();
    float dt = (float)period_s;
    j->dt = dt;
    j->dt_d = period_s;
    j->phase = WL_JUMP_DONE;
    j->elapsed_s = 0.0;
    j->forward = false;
    j->entered = WL_PHASE_NONE;
    wl_lowpass_init(&j->stance, WL_P_JUMP_WEIGHT_TAU, dt);
    j->has_thrust = false;
    j->mean_length = NAN;
    j->lengths[0] = j->lengths[1] = NAN;
    j->mean_angle = NAN;
    wl_lowpass_init(&j->swing, WL_P_JUMP_RUN_UP_SWING_TAU, dt);
    j->settled_s = j->apex_s = j->air_s = 0.0;
    j->hold.active = false;
}

void wl_jump_observe_stance(wl_jump_t *j, float fn_left, float fn_right) {
    if (isfinite(fn_left) && isfinite(fn_right)) wl_lowpass(&j->stance, 0.5f * (fn_left + fn_right) - WL_MASS_AT_AXLE * WL_C_GRAVITY);
}

void wl_jump_start(wl_jump_t *j, bool forward) {
    j->phase = WL_JUMP_SQUAT;
    j->elapsed_s = 0.0;
    j->forward = forward;
    j->entered = WL_JUMP_SQUAT;
    j->has_thrust = false;
    j->hold.active = false;
    j->apex_s = j->air_s = j->settled_s = 0.0;
}

bool wl_jump_done(const wl_jump_t *j) { return j->phase == WL_JUMP_DONE; }

/* the phase table (jump.PHASES): airborne, leg length (<0: the operator's), thrust, hip limit,
   next phase, timeout */
typedef struct {
    bool airborne;
    float leg_length;
    bool thrust;
    float hip_limit;
    wl_jump_phase_t then;
    double timeout_s;
} phase_spec_t;

static const phase_spec_t PHASES[] = {
    [WL_JUMP_SQUAT] = {false, WL_P_JUMP_SQUAT_LENGTH, false, WL_P_HIP_TORQUE_LIMIT, WL_JUMP_THRUST, WL_P_JUMP_SQUAT_TIMEOUT_D},
    [WL_JUMP_THRUST] = {false, -1.0f, true, WL_P_JUMP_HIP_TORQUE_LIMIT, WL_JUMP_RETRACT, WL_P_JUMP_THRUST_TIMEOUT_D},
    [WL_JUMP_RETRACT] = {true, WL_P_JUMP_RETRACT_TARGET, false, WL_P_JUMP_HIP_TORQUE_LIMIT, WL_JUMP_FLIGHT, WL_P_JUMP_RETRACT_TIMEOUT_D},
    [WL_JUMP_FLIGHT] = {true, WL_P_JUMP_LAND_LENGTH, false, WL_P_HIP_TORQUE_LIMIT, WL_JUMP_LAND, WL_P_JUMP_FLIGHT_TIMEOUT_D},
    [WL_JUMP_LAND] = {false, -1.0f, false, WL_P_HIP_TORQUE_LIMIT, WL_JUMP_DONE, WL_P_JUMP_LAND_TIME_D},
};

/* what a phase's exit looks at this tick (jump.JumpView) */
typedef struct {
    double elapsed;
    float length;
    bool touching, steady, rising;
    float pressed;  /* m/s, how fast the faster-shortening leg shortens */
} jump_view_t;

static bool phase_done(wl_jump_phase_t phase, const jump_view_t *v) {
    switch (phase) {
    case WL_JUMP_SQUAT: return v->length < WL_P_JUMP_SQUAT_DONE_LENGTH && v->elapsed > WL_P_JUMP_SQUAT_MIN_S_D && v->steady;
    case WL_JUMP_THRUST: return v->length > WL_P_JUMP_THRUST_END_LENGTH;
    case WL_JUMP_RETRACT: return v->length < WL_P_JUMP_RETRACT_LENGTH;
    case WL_JUMP_FLIGHT:
        return v->touching && v->elapsed > WL_P_JUMP_FLIGHT_MIN_S_D && !v->rising && v->pressed > WL_P_JUMP_TOUCHDOWN_RATE;
    default: return false;
    }
}

static wl_jump_phase_t next_phase(wl_jump_phase_t phase, const jump_view_t *v) {
    if (phase == WL_JUMP_DONE) return phase;
    if (phase_done(phase, v)) return PHASES[phase].then;
    double elapsed = v->elapsed;
    if (elapsed >= PHASES[phase].timeout_s) return PHASES[phase].then;  /* every timeout goes on to the next */
    return phase;
}

float wl_jump_apex_delay(float rate_m_s, float carried_n) {
    if (!(isfinite(rate_m_s) && rate_m_s > 0.0f)) return 0.0f;
    float m = wl_maxf(carried_n, 1e-3f) / WL_C_GRAVITY;
    return rate_m_s * m / (m + WL_MASS_AT_AXLE) / WL_C_GRAVITY;
}

/* the legs' lean has stopped swinging (jump.JumpSequencer._settled) */
static bool run_up_settled(wl_jump_t *j, const float angles[2]) {
    float mean = 0.5f * (angles[0] + angles[1]);
    float rate = isfinite(j->mean_angle) ? (mean - j->mean_angle) / j->dt : 0.0f;
    j->mean_angle = mean;
    float swing = wl_lowpass(&j->swing, rate);
    j->settled_s = fabsf(swing) < WL_P_JUMP_RUN_UP_SWING_TOL ? j->settled_s + j->dt_d : 0.0;
    return j->settled_s >= WL_P_JUMP_RUN_UP_SETTLE_S_D;
}

/* how fast the faster-shortening leg shortens (m/s); 0 before two ticks */
static float pressed_rate(wl_jump_t *j, const float lengths[2]) {
    float pressed = 0.0f;
    if (isfinite(j->lengths[0]) && isfinite(j->lengths[1]))
        pressed = wl_maxf((j->lengths[0] - lengths[0]) / j->dt, (j->lengths[1] - lengths[1]) / j->dt);
    j->lengths[0] = lengths[0];
    j->lengths[1] = lengths[1];
    return pressed;
}

static bool rising(const wl_jump_t *j) {
    return (j->phase == WL_JUMP_RETRACT || j->phase == WL_JUMP_FLIGHT) && j->air_s < j->apex_s;
}

wl_jump_cmd_t wl_jump_step(wl_jump_t *j, const float lengths[2], bool touching, bool steady, const float angles[2],
                           float pitch) {
    bool longer = j->phase == WL_JUMP_THRUST;
    float pick = longer ? wl_maxf(lengths[0], lengths[1]) : wl_minf(lengths[0], lengths[1]);
    float mean_length = 0.5f * (lengths[0] + lengths[1]);
    float rate = isfinite(j->mean_length) ? (mean_length - j->mean_length) / j->dt : 0.0f;
    j->mean_length = mean_length;
    float pressed = pressed_rate(j, lengths);
    bool settled = run_up_settled(j, angles);  /* fed every tick: the swing filter stays current */
    jump_view_t view = {j->elapsed_s, pick, touching, steady && (settled || !j->forward), rising(j), pressed};
    wl_jump_phase_t next = next_phase(j->phase, &view);
    j->entered = next != j->phase ? (int)next : WL_PHASE_NONE;
    if (j->entered != WL_PHASE_NONE) {
        j->phase = next;
        j->elapsed_s = 0.0;
    }
    if (j->entered == WL_JUMP_THRUST) {
        float lo = WL_P_JUMP_CARRIED_RANGE_0 * WL_P_LEG_GRAVITY_FF, hi = WL_P_JUMP_CARRIED_RANGE_1 * WL_P_LEG_GRAVITY_FF;
        float carried = j->stance.has_value ? j->stance.value : WL_P_LEG_GRAVITY_FF;
        carried = isfinite(carried) ? wl_minf(wl_maxf(carried, lo), hi) : WL_P_LEG_GRAVITY_FF;
        j->carried_n = carried;
        j->amplitude_n = wl_jump_thrust_amplitude(carried, WL_P_JUMP_SQUAT_DONE_LENGTH);
        j->has_thrust = true;
        j->hold.active = true;
        for (int i = 0; i < 2; i++) j->hold.axle_offset[i] = lengths[i] * sinf(angles[i]);
        j->hold.pitch = pitch;
    }
    if (j->entered == WL_JUMP_RETRACT) {
        j->apex_s = wl_jump_apex_delay(rate, j->has_thrust ? j->carried_n : WL_P_LEG_GRAVITY_FF);
        j->air_s = 0.0;
    }
    j->elapsed_s += j->dt_d;
    j->air_s += j->dt_d;
    bool up = rising(j);
    wl_jump_cmd_t cmd = {0};
    cmd.phase = j->phase;
    cmd.hip_torque_limit = WL_P_HIP_TORQUE_LIMIT;
    if (j->phase == WL_JUMP_DONE) return cmd;
    const phase_spec_t *spec = &PHASES[j->phase];
    cmd.airborne = spec->airborne;
    cmd.has_leg_length = spec->leg_length > 0.0f;
    cmd.leg_length = spec->leg_length;
    cmd.hip_torque_limit = spec->hip_limit;
    /* the legs stay tucked until the top of the jump (controller/jump.py JumpSequencer.step) */
    cmd.tuck = j->phase == WL_JUMP_RETRACT || (j->phase == WL_JUMP_FLIGHT && up);
    if (cmd.tuck) cmd.leg_length = WL_P_JUMP_RETRACT_TARGET;
    /* pushing, the hips over their start point (a forward jump too); in the air in place only */
    if (spec->thrust || (spec->airborne && !j->forward)) {
        if (j->hold.active) {
            cmd.hold = j->hold;
        } else {
            cmd.hold.active = true;
            cmd.hold.axle_offset[0] = cmd.hold.axle_offset[1] = 0.0f;
            cmd.hold.pitch = pitch;
        }
    }
    if (spec->thrust) {
        float carried = WL_P_LEG_GRAVITY_FF, amplitude;
        if (j->has_thrust) {
            carried = j->carried_n;
            amplitude = j->amplitude_n;
        } else {
            amplitude = wl_jump_thrust_amplitude(carried, WL_P_JUMP_SQUAT_DONE_LENGTH);
        }
        cmd.has_leg_force = true;
        cmd.leg_force = tracked_thrust_force(carried, amplitude, pick, rate);
    }
    return cmd;
}

void wl_recovery_init(wl_recovery_t *r, double period_s) {
    r->dt = (float)period_s;
    r->dt_d = period_s;
    r->phase = WL_RECOVERY_DONE;
    r->elapsed_s = 0.0;
    r->pitch_ref = 0.0f;
    r->entered = WL_PHASE_NONE;
}

bool wl_recovery_active(const wl_recovery_t *r) { return r->phase != WL_RECOVERY_DONE; }

void wl_recovery_start(wl_recovery_t *r) {
    r->phase = WL_RECOVERY_TUCK;
    r->elapsed_s = 0.0;
    r->entered = WL_RECOVERY_TUCK;
}

void wl_recovery_stop(wl_recovery_t *r) {
    r->phase = WL_RECOVERY_DONE;
    r->entered = WL_PHASE_NONE;
}

static float next_pitch_ref(float ref, float measured, float target, float max_step) {
    if (wl_minf(ref, target) <= measured && measured <= wl_maxf(ref, target)) ref = measured;
    return ref + wl_maxf(-max_step, wl_minf(max_step, target - ref));
}

wl_recovery_cmd_t wl_recovery_step(wl_recovery_t *r, const float lengths[2], float pitch, float target_pitch) {
    bool settled = fabsf(r->pitch_ref - target_pitch) < 1e-6f;
    float longest = wl_maxf(lengths[0], lengths[1]);
    wl_recovery_phase_t next = r->phase;
    if (r->phase == WL_RECOVERY_TUCK) {
        bool done = r->elapsed_s > WL_P_RECOVERY_TUCK_MIN_S_D && longest < WL_P_RECOVERY_TUCK_LENGTH + 0.01f;
        if (done || r->elapsed_s >= WL_P_RECOVERY_TUCK_TIMEOUT_D) next = WL_RECOVERY_TILT_UP;
    } else if (r->phase == WL_RECOVERY_TILT_UP) {
        if (settled || r->elapsed_s >= WL_P_RECOVERY_TILT_TIMEOUT_D) next = WL_RECOVERY_DONE;
    }
    r->entered = next != r->phase ? (int)next : WL_PHASE_NONE;
    if (r->entered != WL_PHASE_NONE) {
        r->phase = next;
        r->elapsed_s = 0.0;
        if (next == WL_RECOVERY_TILT_UP) r->pitch_ref = pitch;
    }
    r->elapsed_s += r->dt_d;
    wl_recovery_cmd_t cmd = {0};
    cmd.phase = r->phase;
    if (r->phase == WL_RECOVERY_DONE) return cmd;
    if (r->phase == WL_RECOVERY_TILT_UP) {
        r->pitch_ref = next_pitch_ref(r->pitch_ref, pitch, target_pitch, WL_P_RECOVERY_PITCH_RATE * r->dt);
        cmd.has_pitch = true;
        cmd.pitch = r->pitch_ref;
    }
    cmd.airborne = r->phase == WL_RECOVERY_TUCK;
    cmd.has_leg_length = true;
    cmd.leg_length = WL_P_RECOVERY_TUCK_LENGTH;
    return cmd;
}
