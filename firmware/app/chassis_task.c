#include "chassis_task.h"

#include <math.h>
#include <string.h>

#include "can_rx.h"
#include "chassis_control.h"
#include "detect_task.h"
#include "jump.h"
#include "modes.h"
#include "support.h"
#include "robot.h"
#include "wl_config.h"
#include "wl_math.h"


/* the last run tick's output, read by the next ticks (telemetry.LastOutput) */
typedef struct {
    bool valid;
    float x, x_ref, x_integral, balance_theta, hold_torque, speed, slipping, blocked, speed_ref;
    float pitch, roll, yaw, yaw_ref;
    float L0[2], L0_ref[2], theta[2], T[2], Tp[2];
    float fn[2];
    float jump_phase;
} last_output_t;

/* everything, static (no heap) */
static struct {
    uint32_t period_us;
    float dt;
    uint32_t ticks;
    wl_bus_state_t bus;
    wl_chassis_t chassis;
    wl_mode_t mode;
    bool last_buttons[3];  /* reenable, jump, jump forward */
    bool jump_forward;
    last_output_t last;
    wl_support_t support[2];
    float fn[2];
    wl_contact_t contact;
    wl_jump_t jump;
    wl_recovery_t recovery;
    float recovery_limit;  /* rad from upright past which the recovery has fallen again */
    wl_reenable_t reenable;
    wl_esc_watch_t esc_watch[WL_N_WHEELS];
    /* this tick */
    wl_sensed_t sensed;
    uint8_t faulted;
    wl_detect_report_t report;
    wl_mode_t previous;
} s;

static void on_frame(const hal_frame_t *frame, uint64_t time_us) {
    wl_bus_update(&s.bus, frame, (int64_t)time_us);
}

void chassis_task_init(uint32_t period_us) {
    memset(&s, 0, sizeof s);
    s.period_us = period_us;
    double period_s = (double)period_us * 1e-6;
    s.dt = (float)period_s;
    wl_bus_reset(&s.bus);
    wl_chassis_init(&s.chassis, period_s);
    s.mode = WL_MODE_IDLE;
    for (int i = 0; i < 2; i++) wl_support_init(&s.support[i], s.dt);
    wl_contact_init(&s.contact, s.dt);
    wl_jump_init(&s.jump, period_s);
    wl_recovery_init(&s.recovery, period_s);
    s.recovery_limit = WL_P_RECOVERY_FALL_PITCH;
    wl_reenable_init(&s.reenable, (uint32_t)lrintf(WL_P_REENABLE_WINDOW_S * 1e6f));
    for (int i = 0; i < WL_N_WHEELS; i++) wl_esc_watch_init(&s.esc_watch[i], WL_P_ESC_COMMAND_WINDOW);
    hal_can_on_receive(on_frame);
    hal_task_every(period_us, chassis_task);
}

/* -- chassis_info_update: sensors, estimators, the detect task's report -------------- */
static uint8_t faulted_devices(int64_t now) {
    uint8_t mask = 0;
    for (int j = 0; j < WL_N_JOINTS; j++) {
        if (s.bus.joints[j].faults) mask = (uint8_t)(mask | (1u << j));
    }
    for (int w = 0; w < WL_N_WHEELS; w++) {
        if (wl_reenable_pending(&s.reenable, now)) wl_esc_watch_clear(&s.esc_watch[w]);
        const wl_wheel_fb_t *fb = &s.bus.wheels[w];
        bool fresh = fb->received_us != WL_NEVER_US && now - fb->received_us <= 2 * (int64_t)s.period_us;
        if (fresh && wl_esc_watch_update(&s.esc_watch[w], fb->current, fb->speed, now)) {
            mask = (uint8_t)(mask | (1u << (WL_N_JOINTS + w)));
        }
    }
    return mask;
}

static void chassis_info_update(int64_t now) {
    wl_chassis_observe(&s.chassis, &s.bus, &s.sensed);
    s.faulted = faulted_devices(now);
    int64_t seen[WL_N_DEVICES];
    for (int j = 0; j < WL_N_JOINTS; j++) seen[j] = s.bus.joints[j].received_us;
    for (int w = 0; w < WL_N_WHEELS; w++) seen[WL_N_JOINTS + w] = s.bus.wheels[w].received_us;
    seen[WL_N_JOINTS + WL_N_WHEELS] = s.bus.imu.received_us;
    seen[WL_N_JOINTS + WL_N_WHEELS + 1] = s.bus.op.received_us;
    s.report = wl_detect_check(seen, now, s.faulted);
}

/* -- chassis_ctrl_info_get: the remote and the mode machine --------------------------- */
static bool body_down(const wl_attitude_t *att) {
    if (!s.last.valid) return false;
    float side[2] = {WL_C_LEG_PLANE_Y, -WL_C_LEG_PLANE_Y}, phi0[2];
    for (int i = 0; i < 2; i++) phi0[i] = WL_PI / 2 - s.last.theta[i] + att->pitch;
    return wl_body_clearance(att->roll, att->pitch, side, s.last.L0, phi0) < WL_P_BODY_GROUND_CLEARANCE;
}

static bool lying(void) {
    wl_attitude_t att = wl_chassis_attitude(&s.chassis, &s.bus);
    return wl_recoverable(att.roll, att.pitch, WL_P_FALL_PITCH, WL_P_RECOVERY_LYING_MAX, WL_P_FALL_ROLL);
}

/* RECOVERY_FALL_PITCH, or a little past where it lies when it starts further over (node._fallen_again_past) */
static float fallen_again_past(void) {
    wl_attitude_t att = wl_chassis_attitude(&s.chassis, &s.bus);
    float start = wl_tilt_from_upright(att.roll, att.pitch) + WL_P_RECOVERY_TILT_MARGIN;
    return start > WL_P_RECOVERY_FALL_PITCH ? start : WL_P_RECOVERY_FALL_PITCH;
}

static wl_mode_inputs_t mode_inputs(int64_t now) {
    const wl_operator_t *op = &s.bus.op;
    bool reenable_edge = op->reenable && !s.last_buttons[0];
    bool jump_edge = op->jump && !s.last_buttons[1];
    bool forward_edge = op->jump_forward && !s.last_buttons[2];
    s.last_buttons[0] = op->reenable;
    s.last_buttons[1] = op->jump;
    s.last_buttons[2] = op->jump_forward;
    if (jump_edge || forward_edge) s.jump_forward = forward_edge;
    wl_attitude_t att = s.sensed.valid ? s.sensed.att : wl_chassis_attitude(&s.chassis, &s.bus);
    bool in_air = s.mode == WL_MODE_JUMP || s.mode == WL_MODE_AIRBORNE;
    float pitch_limit = in_air ? WL_P_FALL_PITCH_AIR : WL_P_FALL_PITCH;
    float roll_limit = in_air ? WL_P_FALL_ROLL_AIR : WL_P_FALL_ROLL;
    bool fallen = fabsf(att.pitch) > pitch_limit || fabsf(att.roll) > roll_limit;
    fallen = fallen || (wl_mode_enabled(s.mode) && body_down(&att));
    bool stood = false;
    if (s.mode == WL_MODE_STAND_UP) {
        if (wl_recovery_active(&s.recovery)) {  /* righting itself: only a second tumble counts */
            fallen = !wl_recoverable(att.roll, att.pitch, -1.0f, s.recovery_limit, WL_P_FALL_ROLL);
        } else if (s.last.valid) {
            stood = fabsf(0.5f * (s.last.L0[0] + s.last.L0[1]) - op->leg_length) < 0.01f && fabsf(att.pitch) < 0.1f;
            fallen = fallen || fabsf(s.last.theta[0]) > WL_P_FALL_THETA || fabsf(s.last.theta[1]) > WL_P_FALL_THETA;
        }
    }
    wl_mode_inputs_t in;
    in.sw = (op->mode >= 0 && op->mode <= 2) ? (wl_switch_t)op->mode : WL_SWITCH_ESTOP;  /* unknown: E-stop */
    in.devices_ok = s.report.balance_ok;
    in.reenable = wl_reenable_update(&s.reenable, reenable_edge, !wl_mode_enabled(s.mode), now);
    in.jump = jump_edge || forward_edge;
    in.fallen = fallen;
    in.stood_up = stood;
    in.off_ground = s.contact.airborne;
    in.jump_done = wl_jump_done(&s.jump);
    in.can_rise = !fallen;
    return in;
}

static void chassis_ctrl_info_get(int64_t now) {
    wl_mode_inputs_t in = mode_inputs(now);
    s.previous = s.mode;
    s.mode = wl_next_mode(s.mode, &in);
    if (wl_mode_enabled(s.mode)) wl_reenable_consume(&s.reenable);
    if (s.mode == WL_MODE_JUMP && s.previous != WL_MODE_JUMP) {
        wl_jump_start(&s.jump, s.jump_forward);
    } else if (s.previous == WL_MODE_AIRBORNE && s.mode == WL_MODE_BALANCE) {
        wl_chassis_touchdown(&s.chassis, &s.bus, true);
    }
    if (s.mode == WL_MODE_STAND_UP && s.previous != WL_MODE_STAND_UP && lying()) {
        wl_recovery_start(&s.recovery);
        s.recovery_limit = fallen_again_past();
    } else if (s.mode != WL_MODE_STAND_UP) {
        wl_recovery_stop(&s.recovery);
    }
}

/* -- chassis_control: the command by mode, the chassis, support force ---------------- */
static void leg_lengths(float before_first_run, float lengths[2]) {
    for (int i = 0; i < 2; i++) lengths[i] = s.last.valid ? s.last.L0[i] : before_first_run;
}

static void jump_command(wl_chassis_cmd_t *cmd) {
    float lengths[2], angles[2] = {0.0f, 0.0f};
    leg_lengths(WL_P_LEG_LENGTH_NOMINAL, lengths);
    bool touching = wl_maxf(s.fn[0], s.fn[1]) > WL_P_FN_ON;
    bool steady = !s.jump_forward
                  || (s.last.valid && fabsf(s.last.speed - WL_P_JUMP_FORWARD_SPEED) < WL_P_JUMP_RUN_UP_SPEED_TOL);
    if (s.last.valid) {
        angles[0] = s.last.theta[0];
        angles[1] = s.last.theta[1];
    }
    float pitch = s.last.valid ? s.last.pitch : 0.0f;
    wl_jump_cmd_t jc = wl_jump_step(&s.jump, lengths, touching, steady, angles, pitch);
    if (s.jump.entered == WL_JUMP_LAND) wl_chassis_touchdown(&s.chassis, &s.bus, false);
    bool ahead = s.jump_forward && (jc.phase == WL_JUMP_SQUAT || jc.phase == WL_JUMP_THRUST
                                    || jc.phase == WL_JUMP_RETRACT || jc.phase == WL_JUMP_FLIGHT);
    cmd->speed = ahead ? WL_P_JUMP_FORWARD_SPEED : 0.0f;
    cmd->yaw_rate = 0.0f;
    cmd->airborne = jc.airborne;
    cmd->has_leg_force = jc.has_leg_force;
    cmd->leg_force = jc.leg_force;
    cmd->hip_torque_limit = jc.hip_torque_limit;
    cmd->air_pitch_hold = jc.airborne;
    cmd->stance_hold = jc.hold;
    cmd->air_tuck = jc.tuck;
    if (jc.has_leg_length) cmd->leg_length = jc.leg_length;
}

static void recovery_command(wl_chassis_cmd_t *cmd) {
    float lengths[2];
    leg_lengths(WL_P_LEG_LENGTH_MAX, lengths);
    wl_recovery_cmd_t rc = wl_recovery_step(&s.recovery, lengths, wl_chassis_attitude(&s.chassis, &s.bus).pitch,
                                            cmd->pitch);
    if (s.recovery.entered == WL_RECOVERY_TILT_UP) wl_chassis_reset(&s.chassis, &s.bus);
    cmd->airborne = rc.airborne;
    cmd->air_leg_hold = false;
    if (rc.has_leg_length) cmd->leg_length = rc.leg_length;
    if (rc.has_pitch) {
        cmd->pitch = rc.pitch;
        wl_chassis_follow_position(&s.chassis);
    }
}

static wl_chassis_cmd_t command(void) {
    const wl_operator_t *op = &s.bus.op;
    bool moving = s.mode == WL_MODE_MOVE;
    wl_chassis_cmd_t cmd = wl_chassis_default_cmd();
    cmd.speed = moving ? op->speed : 0.0f;
    cmd.yaw_rate = moving ? op->yaw_rate : 0.0f;
    cmd.leg_length = op->leg_length;
    cmd.pitch = op->pitch;
    cmd.roll = op->roll;
    cmd.trim = s.mode == WL_MODE_BALANCE || s.mode == WL_MODE_MOVE;
    if (s.mode == WL_MODE_AIRBORNE) {
        cmd.airborne = true;
        cmd.air_pitch_hold = true;
        cmd.leg_length = WL_P_AIR_LEG_LENGTH;
    } else if (s.mode == WL_MODE_JUMP) {
        jump_command(&cmd);
    } else if (s.mode == WL_MODE_STAND_UP && wl_recovery_active(&s.recovery)) {
        recovery_command(&cmd);
    }
    return cmd;
}

static void update_support(const wl_sensed_t *sensed) {
    float accel_z = wl_vertical_accel(s.bus.imu.quat, s.bus.imu.accel);
    for (int leg = 0; leg < 2; leg++) {
        int front = wl_joint_of(leg, 0), rear = wl_joint_of(leg, 1);
        s.fn[leg] = wl_support_update(&s.support[leg], &sensed->legs[leg], s.bus.joints[front].torque,
                                      s.bus.joints[rear].torque, WL_JOINTS[front].sign, WL_JOINTS[rear].sign, accel_z);
    }
    wl_contact_update(&s.contact, s.fn[0], s.fn[1], wl_support_trusted(sensed->legs));
    if (s.mode == WL_MODE_BALANCE || s.mode == WL_MODE_MOVE) wl_jump_observe_stance(&s.jump, s.fn[0], s.fn[1]);
}

static void remember(const wl_sensed_t *sensed, const wl_chassis_out_t *out) {
    const wl_chassis_t *c = &s.chassis;
    last_output_t *l = &s.last;
    l->valid = true;
    l->x = c->x;
    l->x_ref = c->x_ref;
    l->x_integral = c->x_integral;
    l->balance_theta = c->balance_theta;
    l->hold_torque = c->balance_point.hold_torque;
    l->speed = out->speed;
    l->slipping = c->slip.slipping ? 1.0f : 0.0f;
    l->blocked = c->blocked;
    l->speed_ref = c->speed_ref;
    l->pitch = sensed->att.pitch;
    l->roll = sensed->att.roll;
    l->yaw = sensed->att.yaw;
    l->yaw_ref = c->yaw_ref;
    for (int i = 0; i < 2; i++) {
        l->L0[i] = sensed->legs[i].L0;
        l->L0_ref[i] = c->leg_ref[i];
        l->theta[i] = sensed->legs[i].theta;
        l->T[i] = out->wheel_t[i];
        l->Tp[i] = out->tp[i];
        l->fn[i] = s.fn[i];
    }
    l->jump_phase = (float)s.jump.phase;
}

/* -- chassis_motors_can_send: this tick's frames -------------------------------------- */
static void send_wheel_currents(const float *currents_a) {
    float sent[4] = {0};  /* the 0x200 frame's four slots */
    for (int w = 0; w < WL_N_WHEELS; w++) {
        float amps = currents_a ? currents_a[w] : 0.0f;
        sent[WL_WHEELS[w].esc_id - 1] = amps;
        wl_esc_watch_commanded(&s.esc_watch[w], wl_esc_current(amps));
    }
    hal_frame_t f = wl_tx_wheel_currents(sent, 4);
    hal_can_send(&f);
}

static void send_enable(void) {  /* stop-and-clear, MIT run mode, enable: the CyberGear start */
    for (int j = 0; j < WL_N_JOINTS; j++) {
        hal_frame_t f = wl_tx_joint_stop(WL_JOINTS[j].motor_id, true);
        hal_can_send(&f);
        f = wl_tx_joint_run_mode(WL_JOINTS[j].motor_id, 0);
        hal_can_send(&f);
        f = wl_tx_joint_enable(WL_JOINTS[j].motor_id);
        hal_can_send(&f);
    }
    send_wheel_currents(NULL);
}

static void chassis_motors_can_send(const wl_chassis_out_t *out) {
    float currents[WL_N_WHEELS];
    for (int j = 0; j < WL_N_JOINTS; j++) {
        hal_frame_t f = wl_tx_joint_torque(WL_JOINTS[j].motor_id, out->hip_torque[j]);
        hal_can_send(&f);
    }
    for (int w = 0; w < WL_N_WHEELS; w++) currents[w] = out->wheel_torque[w] / WL_C_M3508_TORQUE_CONSTANT;
    send_wheel_currents(currents);
}

/* -- chassis_device_offline_handle: motors off -------------------------------------- */
static void chassis_device_offline_handle(int64_t now) {
    /* a CyberGear talks only when spoken to: a stop to each joint each tick brings its feedback
       back for the offline watch; the C620 holds its last command: zero every tick */
    bool clear = wl_reenable_pending(&s.reenable, now);
    for (int j = 0; j < WL_N_JOINTS; j++) {
        hal_frame_t f = wl_tx_joint_stop(WL_JOINTS[j].motor_id, clear);
        hal_can_send(&f);
    }
    send_wheel_currents(NULL);
}

static void chassis_control(void) {
    if (!s.sensed.valid) {  /* enabled without a pose (no IMU, a leg that does not close): hold off */
        chassis_device_offline_handle(INT64_MIN);
        return;
    }
    wl_chassis_cmd_t cmd = command();
    wl_chassis_out_t out;
    wl_chassis_step(&s.chassis, &cmd, &s.sensed, &out);
    update_support(&s.sensed);
    chassis_motors_can_send(&out);
    remember(&s.sensed, &out);
}

void chassis_task(uint64_t now_us) {
    int64_t now = (int64_t)now_us;
    chassis_info_update(now);
    chassis_ctrl_info_get(now);
    bool enabled = wl_mode_enabled(s.mode);
    if (enabled && !wl_mode_enabled(s.previous)) {
        send_enable();
        wl_chassis_reset(&s.chassis, &s.bus);
        wl_contact_reset(&s.contact);
    } else if (enabled) {
        chassis_control();
    } else {
        chassis_device_offline_handle(now);
    }
    s.ticks++;
}

void chassis_shutdown(void) {
    for (int j = 0; j < WL_N_JOINTS; j++) {
        hal_frame_t f = wl_tx_joint_stop(WL_JOINTS[j].motor_id, false);
        hal_can_send(&f);
    }
    float zero[4] = {0};
    hal_frame_t f = wl_tx_wheel_currents(zero, 4);
    hal_can_send(&f);
}

chassis_status_t chassis_status(void) {
    chassis_status_t st;
    st.mode = (uint8_t)s.mode;
    st.offline_mask = s.report.mask;
    st.offline_count = s.report.count;
    st.warning_level = s.report.level;
    st.motors_enabled = wl_mode_enabled(s.mode);
    st.off_ground = s.mode == WL_MODE_AIRBORNE;
    st.fallen = s.mode == WL_MODE_FALLEN;
    st.fault_latched = s.faulted != 0;
    st.bad_frames = s.bus.bad_frames;
    st.ticks = s.ticks;
    return st;
}

const char CHASSIS_DEBUG_NAMES[] =
    "x,x_ref,x_integral,balance_theta,hold_torque,speed,slipping,blocked,speed_ref,pitch,roll,yaw,yaw_ref,"
    "left_L0,left_L0_ref,left_theta,left_T,left_Tp,right_L0,right_L0_ref,right_theta,right_T,right_Tp,"
    "Fn_left,Fn_right,jump_phase";

int chassis_debug(float *values, int max_values) {
    const last_output_t *l = &s.last;
    float v[26] = {l->x, l->x_ref, l->x_integral, l->balance_theta, l->hold_torque, l->speed, l->slipping,
                   l->blocked, l->speed_ref, l->pitch, l->roll, l->yaw, l->yaw_ref,
                   l->L0[0], l->L0_ref[0], l->theta[0], l->T[0], l->Tp[0],
                   l->L0[1], l->L0_ref[1], l->theta[1], l->T[1], l->Tp[1], l->fn[0], l->fn[1], l->jump_phase};
    int n = 0;
    for (; n < 26 && n < max_values; n++) values[n] = v[n];
    return n;
}
