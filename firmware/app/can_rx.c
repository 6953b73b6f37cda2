/* Frame decoders of the receive side (controller/state.py), layouts from wl_config.h. */
#include "can_rx.h"

#include <math.h>
#include <string.h>

#include "dbc_codec.h"
#include "robot.h"


static const wl_signal_t ID_TYPE = WL_CGID_REPLY_TYPE, ID_MOTOR = WL_CGID_REPLY_MOTORID, ID_HOST = WL_CGID_REPLY_HOST;
static const wl_signal_t ID_MODE = WL_CGID_REPLY_MODE;
static const wl_signal_t ID_FAULTS[] = {
    WL_CGID_REPLY_FAULTUNDERVOLTAGE, WL_CGID_REPLY_FAULTOVERCURRENT, WL_CGID_REPLY_FAULTOVERTEMP,
    WL_CGID_REPLY_FAULTMAGENCODER, WL_CGID_REPLY_FAULTHALLENCODER, WL_CGID_REPLY_FAULTNOTCALIBRATED,
};
static const wl_signal_t FB_POS = WL_SIG_CG_FEEDBACK_POS, FB_VEL = WL_SIG_CG_FEEDBACK_VEL;
static const wl_signal_t FB_TORQUE = WL_SIG_CG_FEEDBACK_TORQUE, FB_TEMP = WL_SIG_CG_FEEDBACK_TEMP;
static const wl_signal_t FAULT_WORD[] = {
    WL_SIG_CG_FAULT_WARN_FAULTOVERTEMP, WL_SIG_CG_FAULT_WARN_FAULTDRIVERCHIP, WL_SIG_CG_FAULT_WARN_FAULTUNDERVOLTAGE,
    WL_SIG_CG_FAULT_WARN_FAULTOVERVOLTAGE, WL_SIG_CG_FAULT_WARN_FAULTPHASEBOVERCURRENT,
    WL_SIG_CG_FAULT_WARN_FAULTPHASECOVERCURRENT, WL_SIG_CG_FAULT_WARN_FAULTNOTCALIBRATED,
    WL_SIG_CG_FAULT_WARN_FAULTOVERLOAD, WL_SIG_CG_FAULT_WARN_FAULTPHASEAOVERCURRENT,
};
static const wl_signal_t FAULT_WARN_OTHERS[] = {WL_SIG_CG_FAULT_WARN_WARNOVERTEMP};
static const wl_signal_t ESC_ANGLE = WL_SIG_C620_FB_ROTORANGLE, ESC_SPEED = WL_SIG_C620_FB_ROTORSPEED;
static const wl_signal_t ESC_CURRENT = WL_SIG_C620_FB_TORQUECURRENT, ESC_TEMP = WL_SIG_C620_FB_MOTORTEMP;
/* per IMU frame (quaternion, gyro, accelerometer) its signals; only the quaternion has a fourth */
static const wl_signal_t IMU_SIGS[3][4] = {
    {WL_SIG_IMU_QUAT_QUATW, WL_SIG_IMU_QUAT_QUATX, WL_SIG_IMU_QUAT_QUATY, WL_SIG_IMU_QUAT_QUATZ},
    {WL_SIG_IMU_GYRO_RATEX, WL_SIG_IMU_GYRO_RATEY, WL_SIG_IMU_GYRO_RATEZ, WL_SIG_IMU_GYRO_RATEZ},
    {WL_SIG_IMU_ACCEL_ACCX, WL_SIG_IMU_ACCEL_ACCY, WL_SIG_IMU_ACCEL_ACCZ, WL_SIG_IMU_ACCEL_ACCZ},
};
static const uint8_t IMU_DLC[3] = {WL_DLC_IMU_QUAT, WL_DLC_IMU_GYRO, WL_DLC_IMU_ACCEL};
static const wl_signal_t OP_MODE = WL_SIG_OPERATOR_MODE, OP_JUMP = WL_SIG_OPERATOR_JUMP;
static const wl_signal_t OP_FORWARD = WL_SIG_OPERATOR_JUMPFORWARD, OP_REENABLE = WL_SIG_OPERATOR_REENABLE;
static const wl_signal_t OP_SPEED = WL_SIG_OPERATOR_SPEEDX, OP_YAW = WL_SIG_OPERATOR_YAWRATE;
static const wl_signal_t OP_LEG = WL_SIG_OPERATOR_LEGLENGTH, OP_PITCH = WL_SIG_OPERATOR_PITCH;
static const wl_signal_t OP_ROLL = WL_SIG_OPERATOR_ROLL;

/* The C620 output shaft's rad/s of one rotor rpm */
#define RPM_TO_OUTPUT_RAD_S (2.0f * 3.14159265358979323846f / 60.0f / WL_C_M3508_GEAR)

enum { T_FEEDBACK = 2, T_FAULT_WARN = 21 };

void wl_bus_reset(wl_bus_state_t *bus) {
    memset(bus, 0, sizeof *bus);
    for (int i = 0; i < WL_N_JOINTS; i++) {
        bus->joints[i].temperature = 25.0f;
        bus->joints[i].received_us = WL_NEVER_US;
    }
    for (int i = 0; i < WL_N_WHEELS; i++) {
        bus->wheels[i].temperature = 25.0f;
        bus->wheels[i].received_us = WL_NEVER_US;
    }
    wl_imu_t *imu = &bus->imu;
    imu->quat[0] = 1.0f;
    imu->accel[2] = 9.81f;
    imu->received_us = imu->changed_us = WL_NEVER_US;
    for (int i = 0; i < 3; i++) imu->part_us[i] = WL_NEVER_US;
    bus->op.leg_length = 0.17f;
    bus->op.received_us = WL_NEVER_US;
}

/* decode n signals into out[]; false when any is out of its range (nothing is taken then) */
static bool decode_all(const hal_frame_t *f, uint8_t dlc, const wl_signal_t *sigs, int n, float *out) {
    if (f->dlc != dlc) return false;
    bool ok = true;
    for (int i = 0; i < n; i++) ok = wl_sig_get(f->data, dlc, &sigs[i], &out[i]) && ok;
    return ok;
}

static uint32_t id_field(uint32_t id, const wl_signal_t *field) {
    return (id >> field->shift) & ((1u << field->bits) - 1u);
}

/* CyberGear frames addressed to us (controller/state.py take_cybergear): false for a bad frame */
static bool take_cybergear(wl_bus_state_t *bus, const hal_frame_t *f, int64_t t) {
    uint32_t type = id_field(f->id, &ID_TYPE), motor = id_field(f->id, &ID_MOTOR);
    int j = -1;
    for (int i = 0; i < WL_N_JOINTS; i++) {
        if (WL_JOINTS[i].motor_id == motor) j = i;
    }
    if (j < 0 || id_field(f->id, &ID_HOST) != WL_C_CG_HOST_ID) return true;  /* not ours */
    wl_joint_fb_t *fb = &bus->joints[j];
    if (type == T_FEEDBACK) {
        const wl_signal_t sigs[4] = {FB_POS, FB_VEL, FB_TORQUE, FB_TEMP};
        float v[4];
        if (!decode_all(f, WL_DLC_CG_FEEDBACK, sigs, 4, v)) return false;
        uint8_t faults = 0;
        for (unsigned b = 0; b < 6; b++) {
            if (id_field(f->id, &ID_FAULTS[b])) faults = (uint8_t)(faults | (1u << b));
        }
        fb->position = v[0];
        fb->speed = v[1];
        fb->torque = v[2];
        fb->temperature = v[3];
        fb->mode = (uint8_t)id_field(f->id, &ID_MODE);
        fb->faults = faults;
        fb->received_us = t;
    } else if (type == T_FAULT_WARN) {
        float v[9], w[1];
        if (!decode_all(f, WL_DLC_CG_FAULT_WARN, FAULT_WORD, 9, v)) return false;
        if (!decode_all(f, WL_DLC_CG_FAULT_WARN, FAULT_WARN_OTHERS, 1, w)) return false;
        for (int i = 0; i < 9; i++) {
            if (v[i] != 0.0f) fb->faults |= WL_FAULT_WORD;
        }
    }
    return true;
}

static bool take_wheel(wl_bus_state_t *bus, int w, const hal_frame_t *f, int64_t t) {
    const wl_signal_t sigs[4] = {ESC_ANGLE, ESC_SPEED, ESC_CURRENT, ESC_TEMP};
    float v[4];
    if (!decode_all(f, WL_DLC_C620_FB, sigs, 4, v)) return false;
    wl_wheel_fb_t *fb = &bus->wheels[w];
    fb->rotor_angle = v[0];
    fb->current = v[2];
    fb->speed = v[1] * RPM_TO_OUTPUT_RAD_S;
    fb->temperature = v[3];
    fb->received_us = t;
    return true;
}

/* rig.dbc's three IMU frames (controller/state.py ImuFrames): heard only while they change */
static bool take_imu(wl_imu_t *imu, int part, const hal_frame_t *f, int64_t t) {
    float v[4];
    int n = part == 0 ? 4 : 3;
    if (!decode_all(f, IMU_DLC[part], IMU_SIGS[part], n, v)) return false;
    if (part == 0) {
        float norm = sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3]);
        if (fabsf(norm - 1.0f) > 0.05f) return false;  /* not a unit quaternion */
        for (int i = 0; i < 4; i++) imu->quat[i] = v[i] / norm;
    } else {
        float *dst = part == 1 ? imu->gyro : imu->accel;
        for (int i = 0; i < 3; i++) dst[i] = v[i];
    }
    imu->part_us[part] = t;
    if (!imu->has_data[part] || memcmp(imu->last_data[part], f->data, f->dlc) != 0) {
        memcpy(imu->last_data[part], f->data, f->dlc);
        imu->has_data[part] = true;
        imu->changed_us = t;
    }
    if (imu->part_us[0] != WL_NEVER_US && imu->part_us[1] != WL_NEVER_US && imu->part_us[2] != WL_NEVER_US) {
        int64_t oldest = imu->part_us[0];
        for (int i = 1; i < 3; i++) oldest = imu->part_us[i] < oldest ? imu->part_us[i] : oldest;
        imu->received_us = oldest < imu->changed_us ? oldest : imu->changed_us;
    }
    return true;
}

static bool take_operator(wl_operator_t *op, const hal_frame_t *f, int64_t t) {
    const wl_signal_t sigs[9] = {OP_MODE, OP_JUMP, OP_FORWARD, OP_REENABLE, OP_SPEED, OP_YAW, OP_LEG, OP_PITCH, OP_ROLL};
    float v[9];
    if (!decode_all(f, WL_DLC_OPERATOR, sigs, 9, v)) return false;
    op->mode = (int)v[0];
    op->jump = v[1] != 0.0f;
    op->jump_forward = v[2] != 0.0f;
    op->reenable = v[3] != 0.0f;
    op->speed = v[4];
    op->yaw_rate = v[5];
    op->leg_length = v[6];
    op->pitch = v[7];
    op->roll = v[8];
    op->received_us = t;
    return true;
}

void wl_bus_update(wl_bus_state_t *bus, const hal_frame_t *f, int64_t t) {
    bus->frames++;
    bool ok = true;  /* a DLC other than its message's (9..15 included) fails that message's decode */
    if (f->extended) {
        if (f->bus == HAL_CAN2) ok = take_cybergear(bus, f, t);
    } else if (f->id == WL_ID_SYNC) {
        ok = f->dlc == WL_DLC_SYNC;  /* the port's business (lockstep over real buses) */
    } else if (f->bus == HAL_CAN1) {
        bool done = false;
        for (int w = 0; w < WL_N_WHEELS && !done; w++) {
            if (f->id == (WL_ID_C620_FB - 1u) + WL_WHEELS[w].esc_id) {
                ok = take_wheel(bus, w, f, t);
                done = true;
            }
        }
        if (!done) {
            if (f->id == WL_ID_IMU_QUAT) ok = take_imu(&bus->imu, 0, f, t);
            else if (f->id == WL_ID_IMU_GYRO) ok = take_imu(&bus->imu, 1, f, t);
            else if (f->id == WL_ID_IMU_ACCEL) ok = take_imu(&bus->imu, 2, f, t);
            else if (f->id == WL_ID_OPERATOR) ok = take_operator(&bus->op, f, t);
        }
    }
    if (!ok) bus->bad_frames++;
}
