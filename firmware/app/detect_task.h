/* The detect task (controller/detect.py; the design document's detect_task): a threshold and
   a warning level per device, all offline at power-on; the C620 watch (a hung ESC) and the
   operator's Reenable press. Times in us. */
#ifndef WL_DETECT_TASK_H
#define WL_DETECT_TASK_H

#include <stdbool.h>
#include <stdint.h>

#include "wl_config.h"

typedef struct {
    uint8_t mask, count, level;  /* heartbeat OfflineMask, OfflineCount, WarningLevel */
    bool balance_ok;
} wl_detect_report_t;

/* Which devices are offline at now_us given when each was last heard (WL_DEVICE order);
   faulted_mask: devices reporting a fault, counted as offline. */
wl_detect_report_t wl_detect_check(const int64_t last_seen_us[WL_N_DEVICES], int64_t now_us, uint8_t faulted_mask);

typedef struct {
    int64_t until_us;
    uint32_t window_us;
} wl_reenable_t;

void wl_reenable_init(wl_reenable_t *r, uint32_t window_us);
bool wl_reenable_update(wl_reenable_t *r, bool pressed, bool motors_off, int64_t now_us);
bool wl_reenable_pending(const wl_reenable_t *r, int64_t now_us);
void wl_reenable_consume(wl_reenable_t *r);

#define WL_ESC_WINDOW_MAX 8
typedef struct {
    float commands[WL_ESC_WINDOW_MAX];  /* A, newest last */
    int window, n;
    int64_t since_us;
    bool mismatching, latched;
} wl_esc_watch_t;

void wl_esc_watch_init(wl_esc_watch_t *w, int window);
void wl_esc_watch_commanded(wl_esc_watch_t *w, float current_a);
bool wl_esc_watch_update(wl_esc_watch_t *w, float reported_a, float speed_rad_s, int64_t now_us);
void wl_esc_watch_clear(wl_esc_watch_t *w);

#endif
