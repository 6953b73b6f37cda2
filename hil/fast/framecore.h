/* Shared declarations of the compiled record path (hil/fast/): see _framecore.c. */
#ifndef WHEELLEG_FRAMECORE_H
#define WHEELLEG_FRAMECORE_H
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <structmember.h>
#include <stdint.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------ */
/* Queued: one frame waiting for (or put on) a wire (wire_order.Queued)                         */

typedef struct Item {
    PyObject_HEAD
    PyObject *frame;         /* the Frame record the sinks get */
    int64_t wire_ns;         /* its transmission time */
    int64_t prio, seq;       /* arbitration key: priority, then queueing order */
    int64_t ready_ns;        /* when queued (valid if has_ready) */
    int64_t delay_ns;        /* a reply: after the end of the frame it answers */
    int64_t end_ns;          /* end of transmission (valid if has_end) */
    int has_ready, has_end, wire;
    int is_error, is_sync;   /* noted with the frame */
    struct Item *reply_head, *reply_tail, *reply_next;  /* replies queued before it was sent */
} Item;

extern PyTypeObject ItemType, CoreType;

static inline int key_less(const Item *a, const Item *b) {
    return a->prio < b->prio || (a->prio == b->prio && a->seq < b->seq);
}

static inline int timed_less(const Item *a, const Item *b) {
    return a->ready_ns < b->ready_ns || (a->ready_ns == b->ready_ns && key_less(a, b));
}

/* ------------------------------------------------------------------------------------------ */
/* Growable arrays: a binary heap (heapq's order for distinct keys) and a FIFO                   */

typedef struct { Item **v; Py_ssize_t n, cap; } Heap;
typedef struct { Item **v; Py_ssize_t head, n, cap; } Fifo;

static inline Item *fifo_front(Fifo *q) { return q->n ? q->v[q->head] : NULL; }

static inline Item *fifo_pop(Fifo *q) {
    Item *it = q->v[q->head++];
    if (--q->n == 0)
        q->head = 0;
    return it;
}

/* ------------------------------------------------------------------------------------------ */
/* One bus's wire (wire_order.BusWire)                                                          */

typedef struct {
    int64_t free_ns, busy_ns_total, frames_total, seq;
    Py_ssize_t unresolved;
    Fifo controller;  /* the controller's transmit queue */
    Heap timed;       /* (ready, key): every other node's frames whose queueing time is known */
    Heap eligible;    /* (key): those queued by the wire's clock */
    Fifo sent;        /* on the wire, in wire order, not yet taken */
    Item *last;       /* queued last (an error frame flags it); owned */
    int listed;       /* in the recorder's ``wires`` (a frame of it settled, or asked for) */
} Wire;

typedef struct {
    int64_t now_ns;
    int channel, received;
    Item *item;       /* owned */
    Item *answers;    /* owned or NULL */
} Noted;

typedef struct {
    PyObject_HEAD
    Wire *wires;
    int nwires, capwires;
    PyObject *channels;      /* list of channel names, in tie-break order */
    PyObject *index;         /* dict name -> index */
    PyObject *frame_type, *clock, *on_load, *on_full, *wire_ns_py;
    int64_t bitrate, sync_id, response_ns, tick_ns, run_to_ns, load_due_ns, frames;
    Py_ssize_t batch;
    Noted *noted;
    Py_ssize_t nnoted, capnoted;
    /* Frame made slot by slot (its dataclass __init__ is Python code): the 13 slots' offsets, in
     * field order, and the defaults of the last three; 0 offsets: call the class instead */
    Py_ssize_t slot[13];
    PyObject *defaults[4];  /* bus, fd_flags, direction, line_no as the class sets them */
} Core;

/* attribute names, interned once (_framecore.c) */
extern PyObject *s_now_ns, *s_t_ns, *s_arbitration_id, *s_is_extended_id, *s_is_error_frame,
    *s_is_remote_frame, *s_is_fd, *s_data, *s_dlc, *s_empty, *s_channel, *s_is_extended, *s_is_error,
    *s_is_remote, *s_fd_flags;

/* wire.c: frame bits, the wire model */
void init_crc_table(void);
int64_t frame_bits(uint32_t id, int extended, const unsigned char *data, Py_ssize_t len);
PyObject *py_frame_bits(PyObject *self, PyObject *args);
int64_t frame_prio(int64_t id, int extended, int remote);
int heap_push(Heap *h, Item *it, int (*less)(const Item *, const Item *));
int fifo_push(Fifo *q, Item *it);
void wire_clear(Wire *w);
void wire_queued(Wire *w, Item *it, int64_t ready_ns, int has_ready, int is_error, int64_t prio);
int wire_send(Core *c, Wire *w, Item *it, int64_t start_ns);
int wire_run_until(Core *c, Wire *w, int64_t now_ns, int until_none);
int wire_queue(Core *c, Wire *w, Item *it, int64_t ready_ns, Item *answers, int is_error, int64_t prio);

/* frames.c: a Frame and its wire entry from a can.Message */
int core_find_slots(Core *c);
Item *core_item(Core *c, int ch, PyObject *msg);

/* sinks.c: candump lines, /can/ and float64 records */
PyObject *candump_lines(PyObject *self, PyObject *args);
PyObject *pack_plain(PyObject *self, PyObject *frames);
PyObject *pack_floats(PyObject *self, PyObject *args);

#endif
