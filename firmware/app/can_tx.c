#include "can_tx.h"

#include <string.h>

#include "dbc_codec.h"
#include "wl_config.h"
#include "wl_math.h"

static const wl_signal_t ID_TYPE = WL_CGID_REQ_TYPE, ID_HOST = WL_CGID_REQ_HOST, ID_TARGET = WL_CGID_REQ_TARGET;
static const wl_signal_t MOTION_TYPE = WL_CGID_MOTION_TYPE, MOTION_TORQUE = WL_CGID_MOTION_TORQUEREF;
static const wl_signal_t MOTION_TARGET = WL_CGID_MOTION_TARGET;
static const wl_signal_t MOTION_SIGS[4] = {WL_SIG_CG_MOTION_POSREF, WL_SIG_CG_MOTION_VELREF, WL_SIG_CG_MOTION_KP,
                                           WL_SIG_CG_MOTION_KD};
static const wl_signal_t STOP_CLEAR = WL_SIG_CG_STOP_CLEARFAULT;
static const wl_signal_t WRITE_INDEX = WL_SIG_CG_PARAM_WRITE_INDEX, WRITE_RUN_MODE = WL_SIG_CG_PARAM_WRITE_RUN_MODE;
static const wl_signal_t ESC_SLOTS[4] = {WL_SIG_C620_CMD_ESC1_CURRENT, WL_SIG_C620_CMD_ESC2_CURRENT,
                                        WL_SIG_C620_CMD_ESC3_CURRENT, WL_SIG_C620_CMD_ESC4_CURRENT};
static const wl_signal_t HB_TICK = WL_SIG_HEARTBEAT_TICK, HB_MODE = WL_SIG_HEARTBEAT_MODE;
static const wl_signal_t HB_LEVEL = WL_SIG_HEARTBEAT_WARNINGLEVEL, HB_COUNT = WL_SIG_HEARTBEAT_OFFLINECOUNT;
static const wl_signal_t HB_MASK = WL_SIG_HEARTBEAT_OFFLINEMASK, HB_ENABLED = WL_SIG_HEARTBEAT_MOTORSENABLED;
static const wl_signal_t HB_OFF_GROUND = WL_SIG_HEARTBEAT_OFFGROUND, HB_FALLEN = WL_SIG_HEARTBEAT_FALLEN;
static const wl_signal_t HB_LATCHED = WL_SIG_HEARTBEAT_FAULTLATCHED, HB_BAD = WL_SIG_HEARTBEAT_BADFRAMES;

enum { T_MOTION = 1, T_ENABLE = 3, T_STOP = 4, T_PARAM_WRITE = 18 };
#define RUN_MODE_INDEX 0x7005

static uint32_t id_put(const wl_signal_t *field, uint32_t value) {
    return (value & ((1u << field->bits) - 1u)) << field->shift;
}

static uint32_t request_id(uint32_t type, uint8_t motor) {
    return id_put(&ID_TYPE, type) | id_put(&ID_HOST, WL_C_CG_HOST_ID) | id_put(&ID_TARGET, motor);
}

static hal_frame_t frame(uint32_t id, bool extended, uint8_t bus, uint8_t dlc) {
    hal_frame_t f;
    memset(&f, 0, sizeof f);
    f.id = id;
    f.extended = extended ? 1 : 0;
    f.bus = bus;
    f.dlc = dlc;
    return f;
}

hal_frame_t wl_tx_joint_torque(uint8_t motor_id, float torque_nm) {
    uint32_t id = id_put(&MOTION_TYPE, T_MOTION) | id_put(&MOTION_TORQUE, wl_sig_truncated(&MOTION_TORQUE, torque_nm))
                  | id_put(&MOTION_TARGET, motor_id);
    hal_frame_t f = frame(id, true, HAL_CAN2, WL_DLC_CG_MOTION);
    /* set points and gains 0 (the truncating encoder's raw of 0: mid-range for PosRef, VelRef) */
    for (int i = 0; i < 4; i++) {
        uint32_t raw = (i < 2) ? wl_sig_truncated(&MOTION_SIGS[i], 0.0f) : 0u;
        wl_sig_put_raw(f.data, f.dlc, &MOTION_SIGS[i], raw);
    }
    return f;
}

hal_frame_t wl_tx_joint_enable(uint8_t motor_id) {
    return frame(request_id(T_ENABLE, motor_id), true, HAL_CAN2, WL_DLC_CG_ENABLE);
}

hal_frame_t wl_tx_joint_stop(uint8_t motor_id, bool clear_fault) {
    hal_frame_t f = frame(request_id(T_STOP, motor_id), true, HAL_CAN2, WL_DLC_CG_STOP);
    wl_sig_put_raw(f.data, f.dlc, &STOP_CLEAR, clear_fault ? 1 : 0);
    return f;
}

hal_frame_t wl_tx_joint_run_mode(uint8_t motor_id, uint8_t run_mode) {
    hal_frame_t f = frame(request_id(T_PARAM_WRITE, motor_id), true, HAL_CAN2, WL_DLC_CG_PARAM_WRITE);
    wl_sig_put_raw(f.data, f.dlc, &WRITE_INDEX, RUN_MODE_INDEX);
    wl_sig_put_raw(f.data, f.dlc, &WRITE_RUN_MODE, run_mode);
    return f;
}

float wl_esc_current(float amps) {
    return wl_within(amps, -WL_C_C620_CURRENT_LIMIT, WL_C_C620_CURRENT_LIMIT);
}

hal_frame_t wl_tx_wheel_currents(const float *currents_a, int n) {
    hal_frame_t f = frame(WL_ID_C620_CMD, false, HAL_CAN1, WL_DLC_C620_CMD);
    for (int i = 0; i < 4; i++) {
        float amps = i < n ? wl_esc_current(currents_a[i]) : 0.0f;
        wl_sig_put_raw(f.data, f.dlc, &ESC_SLOTS[i], wl_sig_rounded(&ESC_SLOTS[i], amps));
    }
    return f;
}

hal_frame_t wl_tx_heartbeat(const wl_heartbeat_t *hb, uint8_t bus) {
    hal_frame_t f = frame(WL_ID_HEARTBEAT, false, bus, WL_DLC_HEARTBEAT);
    wl_sig_put_raw(f.data, f.dlc, &HB_TICK, hb->tick);
    wl_sig_put_raw(f.data, f.dlc, &HB_MODE, hb->mode);
    wl_sig_put_raw(f.data, f.dlc, &HB_LEVEL, hb->warning_level > 15 ? 15 : hb->warning_level);
    wl_sig_put_raw(f.data, f.dlc, &HB_COUNT, hb->offline_count > 15 ? 15 : hb->offline_count);
    wl_sig_put_raw(f.data, f.dlc, &HB_MASK, hb->offline_mask);
    wl_sig_put_raw(f.data, f.dlc, &HB_ENABLED, hb->motors_enabled);
    wl_sig_put_raw(f.data, f.dlc, &HB_OFF_GROUND, hb->off_ground);
    wl_sig_put_raw(f.data, f.dlc, &HB_FALLEN, hb->fallen);
    wl_sig_put_raw(f.data, f.dlc, &HB_LATCHED, hb->fault_latched);
    wl_sig_put_raw(f.data, f.dlc, &HB_BAD, hb->bad_frames & 0xFu);
    return f;
}
