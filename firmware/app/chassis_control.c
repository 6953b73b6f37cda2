#include "chassis_control.h"

#include <math.h>
#include <string.h>

#include "fivebar.h"
#include "lqr.h"
#include "robot.h"
#include "wl_config.h"
#include "wl_math.h"


void wl_chassis_init(wl_chassis_t *c, double period_s) {
    memset(c, 0, sizeof *c);
    float dt = (float)period_s;
    c->dt = dt;
    c->dt_d = period_s;
    c->travel = WL_TRAVEL_STANDING;
    c->dither_sign = 1.0f;
    c->leg_ref[0] = c->leg_ref[1] = WL_P_LEG_LENGTH_NOMINAL;
    wl_gyro_bias_init(&c->gyro, dt, WL_P_GYRO_BIAS_OMEGA, WL_P_GYRO_BIAS_LIMIT);
    wl_slip_init(&c->slip, dt, WL_P_SLIP_GAIN, WL_P_SLIP_ON, WL_P_SLIP_GRIP_WINDOW, WL_P_SLIP_GRIP_TOL);
    wl_balance_point_init(&c->balance_point, dt, WL_P_BALANCE_POINT_TAU_LEARN, WL_P_BALANCE_POINT_LEARN_S,
                          WL_P_BALANCE_POINT_TAU, WL_P_BALANCE_POINT_STILL, WL_P_BALANCE_POINT_SETTLE_S);
    float k[WL_LQR_INPUTS][WL_LQR_STATES];
    wl_lqr_gains(WL_P_LEG_LENGTH_NOMINAL, k);
    c->speed_to_trim_s = k[0][WL_S_DX] / k[0][WL_S_IX];
}

wl_chassis_cmd_t wl_chassis_default_cmd(void) {
    wl_chassis_cmd_t cmd;
    memset(&cmd, 0, sizeof cmd);
    cmd.leg_length = WL_P_LEG_LENGTH_NOMINAL;
    cmd.air_leg_hold = true;
    cmd.hip_torque_limit = WL_P_HIP_TORQUE_LIMIT;
    return cmd;
}

wl_attitude_t wl_chassis_attitude(const wl_chassis_t *c, const wl_bus_state_t *bus) {
    return wl_attitude(&bus->imu, c->gyro.bias);
}

void wl_chassis_sense(const wl_chassis_t *c, const wl_bus_state_t *bus, wl_sensed_t *s) {
    s->att = wl_chassis_attitude(c, bus);
    s->valid = true;
    for (int leg = 0; leg < 2; leg++) {
        if (!wl_leg_state(bus, leg, &s->att, &s->legs[leg])) s->valid = false;
    }
}

void wl_chassis_observe(wl_chassis_t *c, const wl_bus_state_t *bus, wl_sensed_t *s) {
    s->valid = false;
    if (bus->imu.received_us == WL_NEVER_US) return;
    wl_gyro_bias_update(&c->gyro, bus->imu.quat, bus->imu.gyro);
    wl_chassis_sense(c, bus, s);
    if (!s->valid) return;
    wl_slip_update(&c->slip, wl_forward_accel(bus->imu.quat, bus->imu.accel),
                   wl_mean_speed(s->legs) - wl_legs_under_body(s->legs));
}

void wl_chassis_reset(wl_chassis_t *c, const wl_bus_state_t *bus) {
    wl_sensed_t s;
    wl_chassis_sense(c, bus, &s);
    c->x = c->x_ref = c->x_integral = 0.0f;
    c->trim_hold_s = 0.0;
    memset(c->u_prev, 0, sizeof c->u_prev);
    c->speed_ref = c->accel_ref = c->blocked = 0.0f;
    c->unblock_s = 0.0;
    c->travel = WL_TRAVEL_STANDING;
    c->lean = 0.0f;
    c->yaw_ref = s.att.yaw;
    c->yaw_rate_ref = 0.0f;
    for (int leg = 0; leg < 2; leg++) {
        c->leg_integral[leg] = 0.0f;
        if (s.valid) c->leg_ref[leg] = s.legs[leg].L0;
    }
    c->roll_offset = wl_clamp(c->leg_ref[WL_LEFT] - c->leg_ref[WL_RIGHT], WL_P_ROLL_LEVEL_LIMIT);
}

void wl_chassis_follow_position(wl_chassis_t *c) { c->x_ref = c->x; }

void wl_chassis_touchdown(wl_chassis_t *c, const wl_bus_state_t *bus, bool keep_spot) {
    wl_sensed_t s;
    wl_chassis_sense(c, bus, &s);
    c->x_ref = c->x - (keep_spot ? c->takeoff_error : 0.0f);
    c->yaw_ref = s.att.yaw;
    for (int leg = 0; leg < 2; leg++) {
        if (s.valid) c->leg_ref[leg] = s.legs[leg].L0;
        c->leg_integral[leg] = 0.0f;
    }
}

/* -- pieces -------------------------------------------------------------------------- */
static float roll_set_point(const wl_chassis_t *c, const wl_chassis_cmd_t *cmd) { return cmd->roll + c->lean; }

/* The speed to head for instead of target: 0 while the robot is held back that way
 * (controller/chassis.py _blocked_target). Cruising, the body (the IMU's speed) more than
 * BLOCKED_LAG or the axles (speed, the ground speed) more than BLOCKED_AXLE_LAG behind the set
 * point is held back: the set point and the spot become where the robot is until the command has
 * not asked that way for BLOCKED_RELEASE_S. */
static float blocked_target(wl_chassis_t *c, float target, float speed) {
    float way = copysignf(1.0f, c->speed_ref);
    if (c->travel == WL_TRAVEL_CRUISING && ((c->speed_ref - c->slip.speed) * way > WL_P_BLOCKED_LAG ||
                                            (c->speed_ref - speed) * way > WL_P_BLOCKED_AXLE_LAG)) {
        c->blocked = way;
        c->speed_ref = c->accel_ref = 0.0f;
        c->x_ref = c->x;
    }
    if (target * c->blocked > 0.0f) {
        c->unblock_s = 0.0;
        return 0.0f;
    }
    c->unblock_s += c->dt_d;
    if (c->unblock_s >= WL_P_BLOCKED_RELEASE_S_D) c->blocked = 0.0f;
    return target;
}

static void track_references(wl_chassis_t *c, const wl_chassis_cmd_t *cmd, float speed) {
    float target = blocked_target(c, wl_clamp(cmd->speed, WL_P_SPEED_LIMIT), speed);
    wl_speed_set_point(&c->speed_ref, &c->accel_ref, target, c->dt);
    c->travel = wl_travel_phase(c->speed_ref, c->accel_ref);
    c->x_ref += c->speed_ref * c->dt;
    if (c->travel == WL_TRAVEL_SPEEDING_UP || c->travel == WL_TRAVEL_CRUISING) {
        c->x_ref = c->x;  /* speed alone is tracked; the trim takes up a disturbance */
    } else if (c->travel == WL_TRAVEL_BRAKING || c->trim_hold_s > 0.0) {
        c->x_ref = c->x - wl_clamp(c->x - c->x_ref, WL_P_POSITION_ERROR_LIMIT);
    }
    float yaw_rate = wl_clamp(cmd->yaw_rate, WL_P_YAW_RATE_LIMIT);
    c->yaw_rate_ref += wl_clamp(yaw_rate - c->yaw_rate_ref, WL_P_YAW_ACCEL_LIMIT * c->dt);
    c->yaw_ref = wl_wrap(c->yaw_ref + c->yaw_rate_ref * c->dt);
    float target_lean = wl_turn_lean(c->speed_ref, c->yaw_rate_ref);
    c->lean += (target_lean - c->lean) * wl_minf(1.0f, c->dt / WL_P_TURN_LEAN_TAU);
    float diff = wl_roll_leg_difference(roll_set_point(c, cmd), c->roll_offset);
    float targets[2];
    wl_leg_targets(cmd->leg_length, diff, targets);
    for (int leg = 0; leg < 2; leg++) {
        c->leg_ref[leg] += wl_clamp(targets[leg] - c->leg_ref[leg], WL_P_LEG_LENGTH_RATE * c->dt);
    }
}

static float weight_ratio(const wl_chassis_t *c) {
    float extra = 0.5f * (c->leg_integral[0] + c->leg_integral[1]);
    return wl_maxf(0.5f, 1.0f + extra / WL_P_LEG_GRAVITY_FF);
}

static float position_error(const wl_chassis_t *c, float leg_length) {
    return c->x - c->x_ref + leg_length * sinf(c->balance_theta);
}

/* the position (standing) or speed (cruising) error into x_integral; true when it integrated
   standing still and settled (chassis._trim) */
static bool trim(wl_chassis_t *c, float speed, const wl_chassis_cmd_t *cmd, float leg_length) {
    if (c->travel == WL_TRAVEL_SPEEDING_UP || c->travel == WL_TRAVEL_BRAKING) {
        c->trim_hold_s = c->travel == WL_TRAVEL_SPEEDING_UP ? WL_P_CRUISE_SETTLE_S_D : WL_P_TRIM_SETTLE_S_D;
        return false;
    }
    c->trim_hold_s = c->trim_hold_s - c->dt_d;
    if (c->trim_hold_s < 0.0) c->trim_hold_s = 0.0;
    if (!cmd->trim || c->trim_hold_s > 0.0) return false;
    if (c->travel == WL_TRAVEL_CRUISING) {
        float error = speed - c->speed_ref;
        if (fabsf(error) < WL_P_CRUISE_TRIM_WINDOW * fabsf(c->speed_ref)) {
            float step = c->speed_to_trim_s / WL_P_CRUISE_TRIM_TAU * error * c->dt;
            c->x_integral = wl_clamp(c->x_integral + step, WL_P_POSITION_INTEGRAL_LIMIT);
        }
        return false;
    }
    float error = position_error(c, leg_length);
    if (fabsf(error) >= WL_P_POSITION_ERROR_LIMIT) {
        c->x_integral = wl_unwind(c->x_integral, wl_clamp(error, WL_P_POSITION_ERROR_LIMIT) * c->dt);
        return false;
    }
    c->x_integral = wl_clamp(c->x_integral + error * c->dt, WL_P_POSITION_INTEGRAL_LIMIT);
    return true;
}

static bool is_travel(int state) { return state == WL_S_X || state == WL_S_DX || state == WL_S_IX; }

/* u = u_ref - K (s - s_ref) of one leg about the balance point */
static void lqr_leg(wl_chassis_t *c, const wl_leg_state_t *leg, int name, float speed, const wl_attitude_t *att,
                    const wl_chassis_cmd_t *cmd, float mean_length, float *t, float *tp) {
    float k[WL_LQR_INPUTS][WL_LQR_STATES];
    wl_lqr_gains(leg->L0, k);
    if (cmd->stance_hold.active) {  /* a jump pushing in place: the hips over their start point */
        float theta_ref, dtheta_ref;
        wl_hold_leg_angle(cmd->stance_hold.axle_offset[name], leg->L0, leg->dL0, &theta_ref, &dtheta_ref);
        float err[WL_LQR_STATES] = {leg->theta - theta_ref, leg->dtheta - dtheta_ref, 0.0f, 0.0f,
                                    cmd->stance_hold.pitch - att->pitch, -att->wy, 0.0f, c->u_prev[name][0],
                                    c->u_prev[name][1]};
        *t = -wl_lqr_dot(k[0], err, WL_LQR_STATES);
        *tp = -wl_lqr_dot(k[1], err, WL_LQR_STATES);
        if (cmd->has_leg_force) *tp -= cmd->leg_force * leg->L0 * tanf(leg->theta);
        return;
    }
    float phi = -att->pitch, dphi = -att->wy;
    float hold = c->balance_point.hold_torque;
    float err[WL_LQR_STATES] = {
        leg->theta - c->balance_theta - WL_P_LEAN_PER_ACCEL * c->accel_ref, leg->dtheta,
        wl_clamp(position_error(c, mean_length), WL_P_POSITION_ERROR_LIMIT), speed - c->speed_ref,
        phi - (-cmd->pitch), dphi, c->x_integral, c->u_prev[name][0], c->u_prev[name][1] - hold};
    /* the wheel's travel share (x, dx, ix) is limited apart from the balance share */
    float travel = 0.0f, balance = 0.0f;
    for (int j = 0; j < WL_LQR_STATES; j++) {
        if (is_travel(j)) {
            travel += k[0][j] * err[j];
        } else {
            balance += k[0][j] * err[j];
        }
    }
    *t = -balance + wl_clamp(-travel, c->slip.slipping ? WL_P_SLIP_TRAVEL_TORQUE_LIMIT : WL_P_TRAVEL_TORQUE_LIMIT);
    *tp = hold - wl_lqr_dot(k[1], err, WL_LQR_STATES);
}

static float split(const wl_leg_state_t legs[2]) {
    float diff = legs[0].theta - legs[1].theta, ddiff = legs[0].dtheta - legs[1].dtheta;
    return wl_clamp(-(WL_P_SPLIT_KP * diff + WL_P_SPLIT_KD * ddiff), WL_P_SPLIT_LIMIT);
}

static float yaw(const wl_chassis_t *c, const wl_attitude_t *att) {
    float rate_ref = WL_P_YAW_KP * wl_wrap(c->yaw_ref - att->yaw) + c->yaw_rate_ref;
    return wl_clamp(WL_P_YAW_RATE_KP * (rate_ref - att->wz), WL_P_YAW_TORQUE_LIMIT);
}

static float roll(wl_chassis_t *c, const wl_attitude_t *att, const wl_chassis_cmd_t *cmd) {
    float err = roll_set_point(c, cmd) - att->roll;
    c->roll_offset += WL_P_ROLL_LEVEL_KI * err * c->dt;
    c->roll_offset = wl_clamp(c->roll_offset, WL_P_ROLL_LEVEL_LIMIT);
    return wl_clamp(WL_P_ROLL_KP * err - WL_P_ROLL_KD * att->wx, WL_P_ROLL_FORCE_LIMIT);
}

static float leg_force(wl_chassis_t *c, const wl_leg_state_t *leg, int name) {
    float err = c->leg_ref[name] - leg->L0;
    c->leg_integral[name] = wl_clamp(c->leg_integral[name] + WL_P_LEG_KI * err * c->dt, WL_P_LEG_INTEGRAL_LIMIT);
    float pid = WL_P_LEG_KP * err - WL_P_LEG_KD * leg->dL0 + c->leg_integral[name];
    return wl_clamp(pid, WL_P_LEG_FORCE_LIMIT) + WL_P_LEG_GRAVITY_FF * cosf(leg->theta);
}

/* the hips' dry friction added back (controller/friction.py): the way the joint turns or,
 * slower than the speed band, the way it is asked to turn (move: torque beyond holding it) */
static float coulomb_feed_forward(float speed, float move) {
    float turning = wl_clamp(speed / WL_P_HIP_FRICTION_BAND, 1.0f);
    float asked = wl_clamp(move / WL_P_HIP_FRICTION_TORQUE_BAND, 1.0f);
    return WL_C_HIP_FRICTION * (turning + (1.0f - fabsf(turning)) * asked);
}

/* VMC: the leg's push and torque to its two hip shafts, plus the hips' friction feed-forward;
 * tp_move: the share of tp that moves the leg (beyond the balance point's hold torque);
 * dither (N m): + on the front joint, - on the rear, flipped every tick by the caller: it breaks
 * the joints' stiction each half period; its reaction on the body cancels (chassis._hips) */
static void hips(wl_chassis_out_t *out, int leg, const wl_leg_state_t *s, float force, float tp, float tp_move,
                 float dither) {
    float t1, t4, m1, m4;
    wl_fivebar_joint_torques(&s->kin, force, tp, &t1, &t4);
    wl_fivebar_joint_torques(&s->kin, 0.0f, tp_move, &m1, &m4);
    t1 += coulomb_feed_forward(s->dphi1, m1);
    t4 += coulomb_feed_forward(s->dphi4, m4);
    t1 += dither;
    t4 -= dither;
    int front = wl_joint_of(leg, 0), rear = wl_joint_of(leg, 1);
    out->hip_torque[front] = (float)WL_JOINTS[front].sign * t1;
    out->hip_torque[rear] = (float)WL_JOINTS[rear].sign * t4;
}

/* on saturation scale all four hips by one factor: keeps their direction */
static void limit_hips(wl_chassis_out_t *out, float limit) {
    float peak = 0.0f;
    for (int i = 0; i < WL_N_JOINTS; i++) peak = wl_maxf(peak, fabsf(out->hip_torque[i]));
    if (peak > limit) {
        float scale = limit / peak;
        for (int i = 0; i < WL_N_JOINTS; i++) out->hip_torque[i] *= scale;
    }
}

/* the ground speed's change (m/s^2), lagged by BALANCE_POINT_ACCEL_TAU: every tick, in the air too */
static void track_accel(wl_chassis_t *c, float speed) {
    float accel = (speed - c->speed_prev) / c->dt;
    c->speed_prev = speed;
    c->accel += (accel - c->accel) * wl_minf(1.0f, c->dt / WL_P_BALANCE_POINT_ACCEL_TAU);
}

static float ground_speed(const wl_chassis_t *c, const wl_leg_state_t legs[2]) {
    if (c->slip.slipping) return c->slip.speed + wl_legs_under_body(legs);
    return wl_mean_speed(legs);
}

/* leg force (N, lengthening +) of the in-air leg PD from the length error (m) and rate (m/s);
   tuck: the retraction's stiffer PD (controller/chassis.py air_leg_force) */
static float air_leg_force(float error, float rate, bool tuck) {
    if (tuck) {
        return wl_clamp(WL_P_JUMP_RETRACT_KP * error - WL_P_JUMP_RETRACT_KD * rate, WL_P_JUMP_RETRACT_FORCE_LIMIT);
    }
    return wl_clamp(WL_P_LEG_KP * error - WL_P_LEG_KD * rate, WL_P_AIR_LEG_FORCE_LIMIT);
}

static void air_step(wl_chassis_t *c, const wl_sensed_t *s, float speed, const wl_chassis_cmd_t *cmd,
                     wl_chassis_out_t *out) {
    c->x_ref = c->x;
    c->yaw_ref = s->att.yaw;
    float levelling = 0.0f;
    if (cmd->air_pitch_hold) {
        levelling = wl_clamp(WL_P_AIR_PITCH_KP * (s->att.pitch - cmd->pitch) + WL_P_AIR_PITCH_KD * s->att.wy,
                             WL_P_WHEEL_TORQUE_LIMIT);
    }
    for (int leg = 0; leg < 2; leg++) {
        const wl_leg_state_t *l = &s->legs[leg];
        c->leg_ref[leg] = wl_within(cmd->leg_length, WL_P_LEG_LENGTH_MIN, WL_P_LEG_LENGTH_MAX);
        out->wheel_t[leg] = levelling;
        float theta_ref = 0.0f, dtheta_ref = 0.0f;
        if (cmd->stance_hold.active) {
            wl_hold_leg_angle(cmd->stance_hold.axle_offset[leg], l->L0, l->dL0, &theta_ref, &dtheta_ref);
        }
        float tp = cmd->air_leg_hold
                       ? -(WL_P_AIR_THETA_KP * (l->theta - theta_ref) + WL_P_AIR_THETA_KD * (l->dtheta - dtheta_ref))
                       : 0.0f;
        tp += out->wheel_t[leg];  /* the wheel's reaction acts on its leg: the hip passes it on */
        out->tp[leg] = tp;
        c->u_prev[leg][0] = 0.0f;
        c->u_prev[leg][1] = tp;
        float force = cmd->has_leg_force ? cmd->leg_force
                                         : air_leg_force(c->leg_ref[leg] - l->L0, l->dL0, cmd->air_tuck);
        hips(out, leg, l, force, tp, tp, 0.0f);
        int w = wl_wheel_of(leg);
        out->wheel_torque[w] = (float)WL_WHEELS[w].forward_sign * out->wheel_t[leg];
    }
    limit_hips(out, cmd->hip_torque_limit);
    out->speed = speed;
}

void wl_chassis_step(wl_chassis_t *c, const wl_chassis_cmd_t *cmd, const wl_sensed_t *s, wl_chassis_out_t *out) {
    memset(out, 0, sizeof *out);
    const wl_leg_state_t *legs = s->legs;
    const wl_attitude_t *att = &s->att;
    float speed = ground_speed(c, legs);
    track_accel(c, speed);
    if (cmd->airborne) {
        if (!c->in_air) {
            c->in_air = true;
            c->takeoff_error = c->x - c->x_ref;
        }
        c->x += c->takeoff_speed * c->dt;  /* the wheels spin free: keep the take-off speed */
        air_step(c, s, speed, cmd, out);
        return;
    }
    c->in_air = false;
    c->takeoff_speed = speed;
    c->x += speed * c->dt;
    float mean_length = 0.5f * (legs[0].L0 + legs[1].L0);
    c->balance_theta = wl_lqr_balance_lean(c->balance_point.hold_torque, mean_length, WL_P_BALANCE_LEAN_LIMIT,
                                           weight_ratio(c));
    track_references(c, cmd, speed);
    bool standing = trim(c, speed, cmd, mean_length);
    c->dither_sign = -c->dither_sign;
    /* standing still on its spot only (trim's settled standing) and with the wheels' grip;
     * slewed on and off (chassis.step) */
    float target = standing && !c->slip.slipping ? WL_P_HIP_DITHER : 0.0f;
    c->dither_size += wl_clamp(target - c->dither_size, WL_P_HIP_DITHER / WL_P_HIP_DITHER_RAMP_S * c->dt);
    float dither = c->dither_sign * c->dither_size;
    float wheel_limit = c->blocked != 0.0f ? WL_P_BLOCKED_WHEEL_TORQUE : WL_P_WHEEL_TORQUE_LIMIT;
    for (int leg = 0; leg < 2; leg++) {
        lqr_leg(c, &legs[leg], leg, speed, att, cmd, mean_length, &out->wheel_t[leg], &out->tp[leg]);
        c->u_prev[leg][0] = wl_clamp(out->wheel_t[leg], wheel_limit);
        c->u_prev[leg][1] = out->tp[leg];
    }
    /* the legs' lean standing still says where the CoM is, whatever the hips' friction holds;
     * less the lean the robot's acceleration asks for */
    float lean = 0.5f * (legs[0].theta + legs[1].theta) - WL_P_LEAN_PER_ACCEL * c->accel;
    wl_balance_point_update(&c->balance_point, wl_lqr_lean_hold_torque(lean, mean_length, weight_ratio(c)), speed,
                            standing);
    float sp = split(legs);
    out->tp[WL_LEFT] += sp;
    out->tp[WL_RIGHT] -= sp;
    float yaw_t = yaw(c, att);
    out->wheel_t[WL_LEFT] -= yaw_t;
    out->wheel_t[WL_RIGHT] += yaw_t;
    float roll_f = roll(c, att, cmd);
    for (int leg = 0; leg < 2; leg++) {
        float sign = leg == WL_LEFT ? 1.0f : -1.0f;
        float push = cmd->has_leg_force ? cmd->leg_force : leg_force(c, &legs[leg], leg);
        hips(out, leg, &legs[leg], push + sign * roll_f, out->tp[leg], out->tp[leg] - c->balance_point.hold_torque,
             dither);
        int w = wl_wheel_of(leg);
        out->wheel_torque[w] = (float)WL_WHEELS[w].forward_sign * wl_clamp(out->wheel_t[leg], wheel_limit);
    }
    limit_hips(out, cmd->hip_torque_limit);
    out->speed = speed;
}
