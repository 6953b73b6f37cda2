/* The firmware's in-process lockstep ABI, version 2 (docs/firmware.md).
 *
 * The rig loads libwheelleg_fw.so and calls wl_step once per control period in virtual
 * time: the period's received frames in, the frames to send out. The rig owns SYNC and
 * the heartbeat (it sends the heartbeat from wl_status, every field the firmware's own);
 * the firmware knows neither. Version 2: wl_status carries every Heartbeat field (version
 * 1 had Mode and OfflineMask only). 
 * C11, no heap: all state is static, reset by wl_init. */
#ifndef WL_LOCKSTEP_H
#define WL_LOCKSTEP_H

#include <stdint.h>

#define WL_ABI_VERSION 2

typedef struct {
    uint32_t id;        /* 11- or 29-bit identifier */
    uint8_t  bus;       /* 0: CAN1 (wheel ESCs, IMU, remote), 1: CAN2 (hip motors) */
    uint8_t  extended;  /* 1: 29-bit identifier */
    uint8_t  dlc;       /* 0..8 */
    uint8_t  pad;
    uint8_t  data[8];
} wl_frame_t;           /* 16 bytes */

/* The heartbeat's fields (rig.dbc Heartbeat) as the firmware set them this tick, the same
   values and bits the Python controller sends. */
typedef struct {
    uint8_t  mode;           /* Mode */
    uint8_t  warning_level;  /* WarningLevel: the highest level among the offline devices, 0 when all is well */
    uint8_t  offline_count;  /* OfflineCount: devices offline or faulted */
    uint8_t  offline_mask;   /* OfflineMask: bit i, device i of the detect task offline or faulted */
    uint8_t  motors_enabled; /* MotorsEnabled: 0 or 1 */
    uint8_t  off_ground;     /* OffGround: 0 or 1 */
    uint8_t  fallen;         /* Fallen: 0 or 1 */
    uint8_t  fault_latched;  /* FaultLatched: 0 or 1 */
    uint32_t bad_frames;     /* malformed frames seen since wl_init (the heartbeat's BadFrames carries the low 4 bits) */
    uint32_t ticks;          /* control ticks run since wl_init */
} wl_status_t;               /* 16 bytes */

int32_t     wl_abi_version(void);        /* returns WL_ABI_VERSION */
const char *wl_build_id(void);           /* static string: program name, version, source hash, compiler */
void        wl_init(uint32_t period_us); /* power-on: every state reset; control period in us (2000) */
/* One control period starting at now_us (bus time, us): rx[0..n_rx) are the frames received
   since the previous call, in arrival order, rx_time_us[i] the time each was received. The
   firmware's receive callback takes them, then its tasks run once for this period. Frames to
   send go to tx[0..max_tx), in send order; returns their count. Never fails on a frame:
   unknown or malformed frames are ignored (counted). */
int32_t     wl_step(uint64_t now_us, const wl_frame_t *rx, const uint64_t *rx_time_us, int32_t n_rx,
                    wl_frame_t *tx, int32_t max_tx);
void        wl_status(wl_status_t *status);
/* The firmware's own debug signals for the rig's /controller/debug record: names as a static
   comma-separated string using the Python controller's debug field names where the quantity is
   the same (SI units), values written into values[0..max) in that order; returns the count. */
const char *wl_debug_names(void);
int32_t     wl_debug(float *values, int32_t max_values);
/* What the firmware sends when stopped (SIGTERM on Linux, E-stop): motors disabled / zero current. */
int32_t     wl_shutdown(wl_frame_t *tx, int32_t max_tx);

#endif
