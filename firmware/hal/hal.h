/* The firmware's hardware abstraction: all the application needs of a port (docs/firmware.md).
 *
 * Four things: send a CAN frame, be called back with each received frame, a microsecond
 * clock, and a periodic task. The application (app/) calls only these; each port
 * (ports/lockstep: the rig's in-process virtual time; ports/linux: SocketCAN; an STM32
 * port: bxCAN/FDCAN and a timer, documented in docs/firmware.md) implements them. */
#ifndef WL_HAL_H
#define WL_HAL_H

#include <stdint.h>

enum { HAL_CAN1 = 0, HAL_CAN2 = 1 };  /* CAN1: wheel ESCs, IMU, remote; CAN2: hip motors */

typedef struct {
    uint32_t id;       /* 11- or 29-bit identifier */
    uint8_t bus;       /* HAL_CAN1 | HAL_CAN2 */
    uint8_t extended;  /* 1: 29-bit identifier */
    uint8_t dlc;       /* 0..8 */
    uint8_t data[8];
} hal_frame_t;

/* Queue one frame for transmission on frame->bus; 0 when queued, -1 when the port's
   queue is full (the frame is dropped and counted by the port). Task context only. */
int hal_can_send(const hal_frame_t *frame);

/* Called for each received frame with its reception time (us, hal_micros' clock). On an
   MCU from the CAN receive interrupt, so it must only copy: the application's callback
   stores the frame's values and returns. */
typedef void (*hal_can_rx_fn)(const hal_frame_t *frame, uint64_t time_us);
void hal_can_on_receive(hal_can_rx_fn callback);

/* Microseconds since power-on, monotonic. */
uint64_t hal_micros(void);

/* Run task(now_us) every period_us from now on (the port's timer): one task, the control
   loop. The port calls it once per period, never re-entered. */
typedef void (*hal_task_fn)(uint64_t now_us);
void hal_task_every(uint32_t period_us, hal_task_fn task);

#endif
