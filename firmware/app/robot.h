/* The robot's wiring (controller/constants.py JOINTS, WHEELS): which motor drives which leg. */
#ifndef WL_ROBOT_H
#define WL_ROBOT_H

#include <stdint.h>

#include "wl_config.h"

typedef struct {
    uint8_t motor_id;  /* CyberGear CAN id on CAN2 */
    uint8_t leg;       /* WL_LEFT, WL_RIGHT */
    uint8_t hip;       /* 0: A (front, phi1), 1: E (rear, phi4) */
    int8_t sign;       /* phi = stop + sign * q */
    float stop;        /* rad, phi with the shaft at 0 (thigh on its stop) */
} wl_joint_t;

typedef struct {
    uint8_t esc_id;       /* C620 id: command slot esc_id - 1 of 0x200, feedback 0x200 + id */
    uint8_t leg;
    int8_t forward_sign;  /* +1 when a positive output turn rolls the robot forward */
} wl_wheel_t;

extern const wl_joint_t WL_JOINTS[WL_N_JOINTS];
extern const wl_wheel_t WL_WHEELS[WL_N_WHEELS];

/* index in WL_JOINTS of leg's hip (0 front, 1 rear); of leg's wheel in WL_WHEELS */
int wl_joint_of(int leg, int hip);
int wl_wheel_of(int leg);

#endif
