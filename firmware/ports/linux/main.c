/* The Linux port: the firmware as a process on two SocketCAN interfaces (docs/firmware.md).
 *
 *   wheelleg-fw [--sync] [--period-us N] CAN1_IFACE CAN2_IFACE
 *
 * CAN1 carries the wheel ESCs, IMU and remote, CAN2 the hip motors (can0 can1 on the
 * robot's computer, vcan0 vcan1 on a desk). Free-running (the default) it ticks on its own
 * clock (clock_nanosleep on CLOCK_MONOTONIC, SCHED_FIFO where the OS allows), as on the
 * robot; it knows nothing of the rig. With --sync its timer is the rig's SYNC frame (0x080):
 * a tick when the same SYNC count has arrived on both buses, answered by the rig's heartbeat
 * (0x710) on both, for lockstep over real buses; only this port knows SYNC. SIGTERM or
 * SIGINT sends the motors-off frames (every joint stopped, zero current) and exits 0. */
#include <errno.h>
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "can_tx.h"
#include "chassis_task.h"
#include "hal.h"
#include "wl_config.h"

static int sockets[2] = {-1, -1};
static hal_can_rx_fn rx_callback;
static hal_task_fn task;
static uint32_t task_period_us = 2000;
static struct timespec start;
static uint64_t sync_clock_us;  /* --sync: the clock is the rig's: ticks x period */
static int sync_mode;
static unsigned long tx_dropped;
static volatile sig_atomic_t stop_requested;

static uint64_t monotonic_us(void) {
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    return (uint64_t)(now.tv_sec - start.tv_sec) * 1000000u + (uint64_t)((now.tv_nsec - start.tv_nsec) / 1000);
}

uint64_t hal_micros(void) { return sync_mode ? sync_clock_us : monotonic_us(); }

int hal_can_send(const hal_frame_t *frame) {
    struct can_frame f;
    memset(&f, 0, sizeof f);
    f.can_id = frame->extended ? (frame->id & CAN_EFF_MASK) | CAN_EFF_FLAG : frame->id & CAN_SFF_MASK;
    f.can_dlc = frame->dlc;
    memcpy(f.data, frame->data, sizeof f.data);
    if (frame->bus > 1 || write(sockets[frame->bus], &f, sizeof f) != (ssize_t)sizeof f) {
        tx_dropped++;  /* a full queue or bus-off: the next tick sends again; detect notices silence */
        return -1;
    }
    return 0;
}

void hal_can_on_receive(hal_can_rx_fn callback) { rx_callback = callback; }

void hal_task_every(uint32_t period_us, hal_task_fn fn) {
    task_period_us = period_us;
    task = fn;
}

static int open_can(const char *name) {
    int s = socket(PF_CAN, SOCK_RAW, CAN_RAW);
    if (s < 0) return -1;
    struct ifreq ifr;
    memset(&ifr, 0, sizeof ifr);
    if (strlen(name) >= sizeof ifr.ifr_name) {
        close(s);
        errno = ENAMETOOLONG;
        return -1;
    }
    strncpy(ifr.ifr_name, name, sizeof ifr.ifr_name - 1);
    if (ioctl(s, SIOCGIFINDEX, &ifr) < 0) {
        close(s);
        return -1;
    }
    struct sockaddr_can addr;
    memset(&addr, 0, sizeof addr);
    addr.can_family = AF_CAN;
    addr.can_ifindex = ifr.ifr_ifindex;
    if (bind(s, (struct sockaddr *)&addr, sizeof addr) < 0) {
        close(s);
        return -1;
    }
    int err_mask = 0;  /* no error frames: the firmware counts what it cannot read, not bus errors */
    setsockopt(s, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof err_mask);
    return s;
}

static void on_signal(int sig) {
    (void)sig;
    stop_requested = 1;
}

/* one received frame: the rig's SYNC is the port's (returns its count), the rest the app's */
static long take_frame(int bus, const struct can_frame *f, uint64_t time_us) {
    if (f->can_id & (CAN_ERR_FLAG | CAN_RTR_FLAG)) return -1;
    hal_frame_t h;
    h.extended = (uint8_t)((f->can_id & CAN_EFF_FLAG) ? 1u : 0u);
    h.id = h.extended ? f->can_id & CAN_EFF_MASK : f->can_id & CAN_SFF_MASK;
    h.bus = (uint8_t)bus;
    h.dlc = f->can_dlc > 8 ? 8 : f->can_dlc;
    memcpy(h.data, f->data, sizeof h.data);
    if (sync_mode && !h.extended && h.id == WL_ID_SYNC) {
        if (h.dlc != WL_DLC_SYNC) return -1;
        return (long)((uint32_t)h.data[0] | (uint32_t)h.data[1] << 8 | (uint32_t)h.data[2] << 16 |
                      (uint32_t)h.data[3] << 24);
    }
    if (rx_callback != NULL) rx_callback(&h, time_us);
    return -1;
}

static void drain(uint64_t time_us) {
    struct can_frame f;
    for (int bus = 0; bus < 2; bus++) {
        while (recv(sockets[bus], &f, sizeof f, MSG_DONTWAIT) == (ssize_t)sizeof f) take_frame(bus, &f, time_us);
    }
}

static void realtime_if_allowed(void) {
    struct sched_param param;
    memset(&param, 0, sizeof param);
    param.sched_priority = 80;
    if (sched_setscheduler(0, SCHED_FIFO, &param) != 0) {
        fprintf(stderr, "wheelleg-fw: no SCHED_FIFO (%s): running at normal priority\n", strerror(errno));
    }
    mlockall(MCL_CURRENT | MCL_FUTURE);
}

static int64_t ns_of(const struct timespec *t) { return (int64_t)t->tv_sec * 1000000000 + t->tv_nsec; }

/* tick k at the first chance after k periods of its own clock; a tick whose whole period passed
 * while it was late (a stall, a machine that runs it too slowly) is skipped, as the Python
 * program's loop does: no burst of stale ticks back to back, and never a busy loop catching up */
static void free_run(void) {
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    const int64_t period_ns = (int64_t)task_period_us * 1000;
    int64_t next_ns = ns_of(&now);
    while (!stop_requested) {
        drain(monotonic_us());
        task(monotonic_us());
        next_ns += period_ns;
        clock_gettime(CLOCK_MONOTONIC, &now);
        if (ns_of(&now) >= next_ns + period_ns) next_ns += (ns_of(&now) - next_ns) / period_ns * period_ns;
        struct timespec next = {(time_t)(next_ns / 1000000000), (long)(next_ns % 1000000000)};
        while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, NULL) == EINTR && !stop_requested) {
        }
    }
}

static void send_heartbeat(uint32_t tick) {
    chassis_status_t st = chassis_status();
    wl_heartbeat_t hb = {tick, st.mode, st.warning_level, st.offline_count, st.offline_mask, st.motors_enabled,
                         st.off_ground, st.fallen, st.fault_latched, st.bad_frames};
    for (uint8_t bus = 0; bus < 2; bus++) {
        hal_frame_t f = wl_tx_heartbeat(&hb, bus);
        hal_can_send(&f);
    }
}

/* --sync: a tick when both buses have had the same SYNC count; frames stamped (last SYNC + 1) periods */
static void sync_run(void) {
    long last_sync[2] = {-1, -1}, last_tick = -1;
    struct pollfd fds[2] = {{sockets[0], POLLIN, 0}, {sockets[1], POLLIN, 0}};
    while (!stop_requested) {
        if (poll(fds, 2, 100) <= 0) continue;
        for (int bus = 0; bus < 2; bus++) {
            struct can_frame f;
            while (recv(sockets[bus], &f, sizeof f, MSG_DONTWAIT) == (ssize_t)sizeof f) {
                uint64_t stamp = last_sync[bus] < 0 ? 0 : (uint64_t)(last_sync[bus] + 1) * task_period_us;
                long count = take_frame(bus, &f, stamp);
                if (count < 0) continue;
                last_sync[bus] = count;
                if (last_sync[0] == last_sync[1] && count != last_tick) {
                    last_tick = count;
                    sync_clock_us = (uint64_t)count * task_period_us;
                    task(sync_clock_us);
                    send_heartbeat((uint32_t)count);
                }
            }
        }
    }
}

static int usage(const char *why) {
    fprintf(stderr, "wheelleg-fw: %s (usage: wheelleg-fw [--sync] [--period-us N] CAN1_IFACE CAN2_IFACE)\n", why);
    return 2;
}

int main(int argc, char **argv) {
    const char *ifaces[2] = {NULL, NULL};
    int n_ifaces = 0;
    uint32_t period_us = (uint32_t)(WL_P_CONTROL_PERIOD * 1e6f + 0.5f);
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--sync") == 0) {
            sync_mode = 1;
        } else if (strcmp(argv[i], "--period-us") == 0 && i + 1 < argc) {
            char *end;
            unsigned long v = strtoul(argv[++i], &end, 10);
            if (*end != '\0' || v < 100 || v > 1000000) return usage("--period-us wants 100..1000000");
            period_us = (uint32_t)v;
        } else if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            printf("wheelleg-fw [--sync] [--period-us N] CAN1_IFACE CAN2_IFACE: the wheel-legged robot's firmware\n");
            return 0;
        } else if (argv[i][0] == '-') {
            return usage("unknown option");
        } else if (n_ifaces < 2) {
            ifaces[n_ifaces++] = argv[i];
        } else {
            return usage("two interfaces, CAN1 then CAN2");
        }
    }
    if (n_ifaces != 2) return usage("two interfaces, CAN1 then CAN2");
    for (int bus = 0; bus < 2; bus++) {
        sockets[bus] = open_can(ifaces[bus]);
        if (sockets[bus] < 0) {
            fprintf(stderr, "wheelleg-fw: cannot open CAN interface %s: %s\n", ifaces[bus], strerror(errno));
            return 1;
        }
    }
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
    clock_gettime(CLOCK_MONOTONIC, &start);
    chassis_task_init(period_us);
    if (!sync_mode) realtime_if_allowed();
    fprintf(stderr, "wheelleg-fw: running on %s/%s, %s\n", ifaces[0], ifaces[1],
            sync_mode ? "ticking on the rig's SYNC" : "free-running on its own clock");
    if (sync_mode) {
        sync_run();
    } else {
        free_run();
    }
    chassis_shutdown();
    if (tx_dropped) fprintf(stderr, "wheelleg-fw: %lu frames could not be sent\n", tx_dropped);
    fprintf(stderr, "wheelleg-fw: stopped after %u ticks; motors disabled\n", (unsigned)chassis_status().ticks);
    return 0;
}
