/* Operating modes (controller/modes.py), after the MIT Cheetah's ControlFSM: an explicit
   table of (from modes, condition, to), checked in order; the first that holds is taken.
   The numbers are rig.dbc's Heartbeat.Mode. */
#ifndef WL_MODES_H
#define WL_MODES_H

#include <stdbool.h>

typedef enum {
    WL_MODE_ESTOP = 0, WL_MODE_IDLE = 1, WL_MODE_STAND_UP = 2, WL_MODE_BALANCE = 3, WL_MODE_MOVE = 4,
    WL_MODE_JUMP = 5, WL_MODE_AIRBORNE = 6, WL_MODE_FALLEN = 7, WL_MODE_DISABLED = 8, WL_N_MODES = 9
} wl_mode_t;

typedef enum { WL_SWITCH_ESTOP = 0, WL_SWITCH_STAND = 1, WL_SWITCH_MOVE = 2 } wl_switch_t;

typedef struct {
    wl_switch_t sw;
    bool devices_ok, reenable, jump, fallen, stood_up, off_ground, jump_done, can_rise;
} wl_mode_inputs_t;

/* the motors are on in this mode */
bool wl_mode_enabled(wl_mode_t mode);
wl_mode_t wl_next_mode(wl_mode_t mode, const wl_mode_inputs_t *in);

#endif
