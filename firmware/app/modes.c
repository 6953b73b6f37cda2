#include "modes.h"

#include <stdint.h>

#define ANY 0xFFFFu
#define FROM(m) (1u << (m))

typedef bool (*condition_fn)(wl_mode_t mode, const wl_mode_inputs_t *in);

bool wl_mode_enabled(wl_mode_t m) {
    return m == WL_MODE_STAND_UP || m == WL_MODE_BALANCE || m == WL_MODE_MOVE || m == WL_MODE_JUMP || m == WL_MODE_AIRBORNE;
}

static bool estop(wl_mode_t m, const wl_mode_inputs_t *in) { return in->sw == WL_SWITCH_ESTOP && m != WL_MODE_ESTOP; }
static bool device_lost(wl_mode_t m, const wl_mode_inputs_t *in) { return wl_mode_enabled(m) && !in->devices_ok; }
static bool fell(wl_mode_t m, const wl_mode_inputs_t *in) { return wl_mode_enabled(m) && in->fallen; }
static bool may_rise(wl_mode_t m, const wl_mode_inputs_t *in) {
    (void)m;
    return in->sw != WL_SWITCH_ESTOP && in->devices_ok && in->can_rise;
}
static bool reenabled(wl_mode_t m, const wl_mode_inputs_t *in) {
    (void)m;
    return in->reenable && in->devices_ok && in->sw != WL_SWITCH_ESTOP;
}
static bool stood(wl_mode_t m, const wl_mode_inputs_t *in) { (void)m; return in->stood_up; }
static bool jump(wl_mode_t m, const wl_mode_inputs_t *in) { (void)m; return in->jump; }
static bool off_ground(wl_mode_t m, const wl_mode_inputs_t *in) { (void)m; return in->off_ground; }
static bool to_move(wl_mode_t m, const wl_mode_inputs_t *in) { (void)m; return in->sw == WL_SWITCH_MOVE; }
static bool to_stand(wl_mode_t m, const wl_mode_inputs_t *in) { (void)m; return in->sw == WL_SWITCH_STAND; }
static bool landed(wl_mode_t m, const wl_mode_inputs_t *in) { (void)m; return in->jump_done; }
static bool touched(wl_mode_t m, const wl_mode_inputs_t *in) { (void)m; return !in->off_ground; }

static const struct {
    uint16_t from;  /* FROM() bits, or ANY */
    condition_fn when;
    wl_mode_t to;
} TRANSITIONS[] = {
    {ANY, estop, WL_MODE_ESTOP},
    {ANY, device_lost, WL_MODE_DISABLED},
    {ANY, fell, WL_MODE_FALLEN},  /* in JUMP and AIRBORNE "fallen" is judged with wider limits */
    {FROM(WL_MODE_ESTOP) | FROM(WL_MODE_IDLE), may_rise, WL_MODE_STAND_UP},
    {FROM(WL_MODE_DISABLED) | FROM(WL_MODE_FALLEN), reenabled, WL_MODE_STAND_UP},
    {FROM(WL_MODE_STAND_UP), stood, WL_MODE_BALANCE},
    {FROM(WL_MODE_BALANCE) | FROM(WL_MODE_MOVE), jump, WL_MODE_JUMP},
    {FROM(WL_MODE_BALANCE) | FROM(WL_MODE_MOVE), off_ground, WL_MODE_AIRBORNE},
    {FROM(WL_MODE_BALANCE), to_move, WL_MODE_MOVE},
    {FROM(WL_MODE_MOVE), to_stand, WL_MODE_BALANCE},
    {FROM(WL_MODE_JUMP), landed, WL_MODE_BALANCE},
    {FROM(WL_MODE_AIRBORNE), touched, WL_MODE_BALANCE},
};

wl_mode_t wl_next_mode(wl_mode_t mode, const wl_mode_inputs_t *in) {
    for (unsigned i = 0; i < sizeof TRANSITIONS / sizeof TRANSITIONS[0]; i++) {
        if ((TRANSITIONS[i].from & FROM(mode)) && TRANSITIONS[i].when(mode, in)) return TRANSITIONS[i].to;
    }
    return mode;
}
