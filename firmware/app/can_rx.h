/* What the robot's buses said: the receive side (controller/state.py). Each received frame
   updates the bus state; a frame that fails its checks is counted in bad_frames and ignored. */
#ifndef WL_CAN_RX_H
#define WL_CAN_RX_H

#include <stdbool.h>
#include <stdint.h>

#include "hal.h"
#include "wl_config.h"

#define WL_NEVER_US INT64_MIN  /* a device never heard */

/* CyberGear fault bits of a type-2 id (dbc/cybergear_id.dbc CG_Id_Reply) and a type-21 fault word */
enum { WL_FAULT_ID_BITS = 0x3F, WL_FAULT_WORD = 0x40 };

typedef struct {
    float position, speed, torque, temperature;  /* rad, rad/s, N m, degC (shaft side) */
    uint8_t mode;    /* 0 reset, 2 run */
    uint8_t faults;  /* WL_FAULT_* bits; 0 when healthy */
    int64_t received_us;
} wl_joint_fb_t;

typedef struct {
    float rotor_angle, speed, current, temperature;  /* deg, rad/s output shaft, A, degC */
    int64_t received_us;
} wl_wheel_fb_t;

typedef struct {
    float quat[4];   /* w, x, y, z body->world */
    float gyro[3];   /* rad/s body frame */
    float accel[3];  /* m/s^2 specific force body frame */
    int64_t received_us;  /* last time all three parts had arrived (and changed) */
    int64_t part_us[3];   /* quat, gyro, accel: when each last arrived */
    uint8_t last_data[3][8];
    bool has_data[3];
    int64_t changed_us;   /* last time any IMU payload differed from the one before */
} wl_imu_t;

typedef struct {
    int mode;  /* 0 ESTOP, 1 STAND, 2 MOVE */
    bool jump, jump_forward, reenable;
    float speed, yaw_rate, leg_length, pitch, roll;  /* m/s, rad/s, m, rad, rad */
    int64_t received_us;
} wl_operator_t;

typedef struct {
    wl_joint_fb_t joints[WL_N_JOINTS];  /* in WL_JOINT_TABLE order */
    wl_wheel_fb_t wheels[WL_N_WHEELS];  /* in WL_WHEEL_TABLE order */
    wl_imu_t imu;
    wl_operator_t op;
    uint32_t bad_frames, frames;
} wl_bus_state_t;

void wl_bus_reset(wl_bus_state_t *bus);
/* Take one frame received at time_us; never fails (a bad frame is counted). */
void wl_bus_update(wl_bus_state_t *bus, const hal_frame_t *frame, int64_t time_us);

#endif
