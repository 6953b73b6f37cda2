/* The frames the firmware sends (controller/messages.py): pure encoders, layouts from wl_config.h. */
#ifndef WL_CAN_TX_H
#define WL_CAN_TX_H

#include <stdbool.h>
#include <stdint.h>

#include "hal.h"

/* CyberGear type-1 motion command carrying only a torque (N m, Kp = Kd = 0) */
hal_frame_t wl_tx_joint_torque(uint8_t motor_id, float torque_nm);
/* CyberGear type-3 enable */
hal_frame_t wl_tx_joint_enable(uint8_t motor_id);
/* CyberGear type-4 stop; clear_fault also clears latched faults */
hal_frame_t wl_tx_joint_stop(uint8_t motor_id, bool clear_fault);
/* CyberGear type-18 write of run_mode (0: operation/MIT mode) */
hal_frame_t wl_tx_joint_run_mode(uint8_t motor_id, uint8_t run_mode);
/* The current (A) a C620 command carries for amps: clamped to the ESC's range */
float wl_esc_current(float amps);
/* C620 0x200 frame: currents_a[i] for ESC id i + 1 (i < n), the other slots 0 */
hal_frame_t wl_tx_wheel_currents(const float *currents_a, int n);
/* The rig's heartbeat (rig.dbc): only a port that speaks the rig's SYNC sends it */
typedef struct {
    uint32_t tick;
    uint8_t mode, warning_level, offline_count, offline_mask;
    bool motors_enabled, off_ground, fallen, fault_latched;
    uint32_t bad_frames;
} wl_heartbeat_t;
hal_frame_t wl_tx_heartbeat(const wl_heartbeat_t *hb, uint8_t bus);

#endif
