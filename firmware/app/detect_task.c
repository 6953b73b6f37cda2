#include "detect_task.h"

#include <math.h>

#include "can_rx.h"

static const struct { uint32_t offline_after_us; uint8_t level; uint8_t needed; } RULES[WL_N_DEVICES] = WL_DETECT_TABLE;

wl_detect_report_t wl_detect_check(const int64_t last_seen_us[WL_N_DEVICES], int64_t now_us, uint8_t faulted_mask) {
    wl_detect_report_t r = {0, 0, 0, true};
    for (int bit = 0; bit < WL_N_DEVICES; bit++) {
        bool silent = last_seen_us[bit] == WL_NEVER_US || now_us - last_seen_us[bit] >= (int64_t)RULES[bit].offline_after_us;
        if ((faulted_mask >> bit) & 1u || silent) {
            r.mask = (uint8_t)(r.mask | (1u << bit));
            r.count++;
            if (RULES[bit].level > r.level) r.level = RULES[bit].level;
            if (RULES[bit].needed) r.balance_ok = false;
        }
    }
    return r;
}

void wl_reenable_init(wl_reenable_t *r, uint32_t window_us) {
    r->window_us = window_us;
    r->until_us = WL_NEVER_US;
}

bool wl_reenable_update(wl_reenable_t *r, bool pressed, bool motors_off, int64_t now_us) {
    if (pressed && motors_off) r->until_us = now_us + r->window_us;
    return wl_reenable_pending(r, now_us);
}

bool wl_reenable_pending(const wl_reenable_t *r, int64_t now_us) { return now_us <= r->until_us; }

void wl_reenable_consume(wl_reenable_t *r) { r->until_us = WL_NEVER_US; }

void wl_esc_watch_init(wl_esc_watch_t *w, int window) {
    w->window = window < 1 ? 1 : window > WL_ESC_WINDOW_MAX ? WL_ESC_WINDOW_MAX : window;
    w->n = 1;
    w->commands[0] = 0.0f;
    w->mismatching = w->latched = false;
    w->since_us = 0;
}

void wl_esc_watch_commanded(wl_esc_watch_t *w, float current_a) {
    if (w->n == w->window) {
        for (int i = 1; i < w->n; i++) w->commands[i - 1] = w->commands[i];
        w->n--;
    }
    w->commands[w->n++] = current_a;
}

static bool follows(const wl_esc_watch_t *w, float reported, float speed) {
    float low = w->commands[0], high = w->commands[0];
    for (int i = 1; i < w->n; i++) {
        low = w->commands[i] < low ? w->commands[i] : low;
        high = w->commands[i] > high ? w->commands[i] : high;
    }
    if (fabsf(speed) > WL_P_ESC_BACK_EMF_FRACTION * WL_C_M3508_NO_LOAD_SPEED && w->commands[w->n - 1] * speed > 0.0f) {
        return true;
    }
    return low - WL_P_ESC_CURRENT_TOLERANCE_A <= reported && reported <= high + WL_P_ESC_CURRENT_TOLERANCE_A;
}

bool wl_esc_watch_update(wl_esc_watch_t *w, float reported, float speed, int64_t now_us) {
    if (follows(w, reported, speed)) {
        w->mismatching = false;
    } else {
        if (!w->mismatching) {
            w->mismatching = true;
            w->since_us = now_us;
        }
        w->latched = w->latched || now_us - w->since_us >= (int64_t)lrintf(WL_P_ESC_MISMATCH_S * 1e6f);
    }
    return w->latched;
}

void wl_esc_watch_clear(wl_esc_watch_t *w) {
    w->latched = false;
    w->mismatching = false;
}
