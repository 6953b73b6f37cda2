/* The in-process lockstep port: the HAL over the ABI of include/wl_lockstep.h.
   wl_step hands the period's frames to the receive callback, runs the task once at the
   period's time and returns what it sent. No SYNC, no heartbeat: the rig does those. */
#include <stddef.h>
#include <string.h>

#include "chassis_task.h"
#include "hal.h"
#include "wl_lockstep.h"

#ifndef WL_SOURCE_HASH
#define WL_SOURCE_HASH "unknown"
#endif
#define WL_STR2(x) #x
#define WL_STR(x) WL_STR2(x)
#ifdef __VERSION__
#define WL_COMPILER __VERSION__
#else
#define WL_COMPILER "unknown compiler"
#endif

static hal_can_rx_fn rx_callback;
static hal_task_fn task;
static uint64_t clock_us;
static wl_frame_t *tx_out;
static int32_t tx_max, tx_count;
static uint32_t tx_dropped;

int hal_can_send(const hal_frame_t *frame) {
    if (tx_out == NULL || tx_count >= tx_max) {
        tx_dropped++;
        return -1;
    }
    wl_frame_t *f = &tx_out[tx_count++];
    memset(f, 0, sizeof *f);
    f->id = frame->id;
    f->bus = frame->bus;
    f->extended = frame->extended;
    f->dlc = frame->dlc;
    memcpy(f->data, frame->data, sizeof f->data);
    return 0;
}

void hal_can_on_receive(hal_can_rx_fn callback) { rx_callback = callback; }
uint64_t hal_micros(void) { return clock_us; }
void hal_task_every(uint32_t period_us, hal_task_fn fn) {
    (void)period_us;  /* the rig calls wl_step once per period */
    task = fn;
}

int32_t wl_abi_version(void) { return WL_ABI_VERSION; }

const char *wl_build_id(void) {
    return "wheelleg-fw 0.1.0 lockstep abi " WL_STR(WL_ABI_VERSION) " src " WL_SOURCE_HASH " cc " WL_COMPILER;
}

void wl_init(uint32_t period_us) {
    rx_callback = NULL;
    task = NULL;
    clock_us = 0;
    tx_out = NULL;
    tx_max = tx_count = 0;
    tx_dropped = 0;
    chassis_task_init(period_us ? period_us : 2000u);
}

/* the frames the task sends go to tx[0..max_tx) (none kept when tx is NULL: counted as dropped) */
static void send_into(wl_frame_t *tx, int32_t max_tx) {
    tx_out = tx;
    tx_max = tx != NULL && max_tx > 0 ? max_tx : 0;
    tx_count = 0;
}

int32_t wl_step(uint64_t now_us, const wl_frame_t *rx, const uint64_t *rx_time_us, int32_t n_rx, wl_frame_t *tx,
                int32_t max_tx) {
    if (task == NULL) wl_init(2000u);
    for (int32_t i = 0; rx != NULL && i < n_rx; i++) {
        hal_frame_t f;
        f.id = rx[i].id;
        f.bus = rx[i].bus;
        f.extended = rx[i].extended;
        f.dlc = rx[i].dlc;
        memcpy(f.data, rx[i].data, sizeof f.data);
        uint64_t t = rx_time_us != NULL ? rx_time_us[i] : now_us;
        clock_us = t;
        if (rx_callback != NULL) rx_callback(&f, t);
    }
    clock_us = now_us;
    send_into(tx, max_tx);
    task(now_us);
    int32_t n = tx_count;
    tx_out = NULL;
    return n;
}

void wl_status(wl_status_t *status) {
    if (status == NULL) return;
    chassis_status_t st = chassis_status();
    memset(status, 0, sizeof *status);
    status->mode = st.mode;
    status->warning_level = st.warning_level;
    status->offline_count = st.offline_count;
    status->offline_mask = st.offline_mask;
    status->motors_enabled = st.motors_enabled;
    status->off_ground = st.off_ground;
    status->fallen = st.fallen;
    status->fault_latched = st.fault_latched;
    status->bad_frames = st.bad_frames;
    status->ticks = st.ticks;
}

const char *wl_debug_names(void) { return CHASSIS_DEBUG_NAMES; }

int32_t wl_debug(float *values, int32_t max_values) {
    if (values == NULL || max_values <= 0) return 0;
    return chassis_debug(values, max_values);
}

int32_t wl_shutdown(wl_frame_t *tx, int32_t max_tx) {
    send_into(tx, max_tx);
    chassis_shutdown();
    int32_t n = tx_count;
    tx_out = NULL;
    return n;
}
