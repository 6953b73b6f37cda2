#include "robot.h"

const wl_joint_t WL_JOINTS[WL_N_JOINTS] = WL_JOINT_TABLE;
const wl_wheel_t WL_WHEELS[WL_N_WHEELS] = WL_WHEEL_TABLE;

int wl_joint_of(int leg, int hip) {
    for (int i = 0; i < WL_N_JOINTS; i++) {
        if (WL_JOINTS[i].leg == leg && WL_JOINTS[i].hip == hip) return i;
    }
    return 0;
}

int wl_wheel_of(int leg) {
    for (int i = 0; i < WL_N_WHEELS; i++) {
        if (WL_WHEELS[i].leg == leg) return i;
    }
    return 0;
}
