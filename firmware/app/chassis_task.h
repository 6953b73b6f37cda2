/* The chassis task, in the seed robot's shape (controller/node.py's Controller): once per
   control period
     chassis_info_update()            the IMU and motors' data: attitude, legs, estimators
     chassis_ctrl_info_get()          the remote's command and the mode machine
     chassis_control()                by mode: kinematics, K(L0), off-ground, jump, torques, VMC
     chassis_device_offline_handle()  motors off when a device is offline, faulted, fallen or E-stopped
     chassis_motors_can_send()        the CAN frames of this period
   The detect task's results (detect_task.h) come in through chassis_info_update. */
#ifndef WL_CHASSIS_TASK_H
#define WL_CHASSIS_TASK_H

#include <stdbool.h>
#include <stdint.h>

#include "can_tx.h"
#include "hal.h"

/* power-on: every state reset; the period in us; registers the receive callback and the task */
void chassis_task_init(uint32_t period_us);
/* one control period at now_us (the HAL's task) */
void chassis_task(uint64_t now_us);
/* the frames that leave the robot safe (every joint stopped, zero current), sent through the HAL */
void chassis_shutdown(void);

typedef struct {
    uint8_t mode, offline_mask, offline_count, warning_level;
    bool motors_enabled, off_ground, fallen, fault_latched;
    uint32_t bad_frames, ticks;
} chassis_status_t;
chassis_status_t chassis_status(void);

/* the debug record (telemetry.DEBUG_FIELDS' names, the Python controller's order) */
extern const char CHASSIS_DEBUG_NAMES[];
int chassis_debug(float *values, int max_values);

#endif
