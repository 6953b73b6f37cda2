/* The rig's per-frame record path in C: the wire model, the candump lines, the /can/ records.
 *
 * A port of hil/bus/wire_order.py + Recorder.settle (hil/bus/recorder.py), busload.frame_bits,
 * the common case of CandumpWriter.on_frames (hil/record/candump.py) and can_batch.pack
 * (hil/record/can_batch.py). The Python modules stay the reference and the fallback: every
 * function here gives the bytes and the order the Python code gives (tests/test_framecore.py
 * runs both on the same frames). Anything outside the common case is handed back to Python.
 *
 * Why C: per frame the Python path made ~8 Python objects (a noted tuple, the wire model's
 * entry, heap tuples, the candump line's pieces) at ~0.1-0.3 us each; here a frame is one
 * small C object (its wire-model entry) next to the Frame record the sinks get.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <structmember.h>
#include <stdint.h>
#include <string.h>

/* ------------------------------------------------------------------------------------------ */
/* CAN frame bits (busload.frame_bits): header, payload, CRC-15, stuff bits, trailer            */

static uint16_t crc_table[256];

static void init_crc_table(void) {
    for (int byte = 0; byte < 256; byte++) {
        uint32_t crc = (uint32_t)byte << 7;
        for (int i = 0; i < 8; i++)
            crc = (crc & 0x4000) ? ((crc << 1) ^ 0x4599) : (crc << 1);
        crc_table[byte] = (uint16_t)(crc & 0x7FFF);
    }
}

typedef struct { int last; int run; int64_t added; } Stuffing;

static inline void stuff_bit(Stuffing *s, int bit) {
    s->run = (bit == s->last) ? s->run + 1 : 1;
    s->last = bit;
    if (s->run == 5) {  /* a complement bit goes in and starts the next run */
        s->last = 1 - bit;
        s->run = 1;
        s->added++;
    }
}

static inline uint32_t crc_byte(uint32_t crc, unsigned byte) {
    return ((crc << 8) & 0x7FFF) ^ crc_table[((crc >> 7) ^ byte) & 0xFF];
}

/* Bits of a classic data frame on the wire (is_remote False, DLC = the payload's length, as
 * busload.wire_ns counts it). The caller keeps id within 29 (extended) or 11 bits and len <= 64. */
static int64_t frame_bits(uint32_t id, int extended, const unsigned char *data, Py_ssize_t len) {
    uint64_t head;
    int head_bits;
    if (extended) {
        head = ((uint64_t)(id >> 18) << 27) | (3ULL << 25) | ((uint64_t)(id & 0x3FFFF) << 7) | (uint64_t)len;
        head_bits = 1 + 11 + 2 + 18 + 3 + 4;
    } else {
        head = ((uint64_t)id << 7) | (uint64_t)len;
        head_bits = 1 + 11 + 3 + 4;
    }
    uint32_t crc = 0;
    for (int shift = ((head_bits + 7) / 8 - 1) * 8; shift >= 0; shift -= 8)
        crc = crc_byte(crc, (unsigned)(head >> shift) & 0xFF);
    Stuffing s = {-1, 0, 0};
    for (int i = head_bits - 1; i >= 0; i--)
        stuff_bit(&s, (int)(head >> i) & 1);
    for (Py_ssize_t k = 0; k < len; k++) {
        crc = crc_byte(crc, data[k]);
        for (int i = 7; i >= 0; i--)
            stuff_bit(&s, (data[k] >> i) & 1);
    }
    for (int i = 14; i >= 0; i--)
        stuff_bit(&s, (int)(crc >> i) & 1);
    return head_bits + 8 * (int64_t)len + 15 + s.added + (1 + 2 + 7 + 3);
}

static PyObject *py_frame_bits(PyObject *self, PyObject *args) {
    unsigned long id;
    int extended;
    Py_buffer data;
    if (!PyArg_ParseTuple(args, "kpy*", &id, &extended, &data))
        return NULL;
    if (id > (extended ? 0x1FFFFFFFUL : 0x7FFUL) || data.len > 64) {
        PyBuffer_Release(&data);
        PyErr_SetString(PyExc_ValueError, "frame_bits: id or length out of range");
        return NULL;
    }
    int64_t bits = frame_bits((uint32_t)id, extended, data.buf, data.len);
    PyBuffer_Release(&data);
    return PyLong_FromLongLong(bits);
}

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

static PyTypeObject ItemType;

static void item_dealloc(Item *it) {
    Py_CLEAR(it->frame);
    Py_CLEAR(it->reply_head);
    it->reply_tail = NULL;
    Py_CLEAR(it->reply_next);
    Py_TYPE(it)->tp_free((PyObject *)it);
}

static PyObject *item_get_frame(Item *it, void *closure) {
    PyObject *f = it->frame ? it->frame : Py_None;
    Py_INCREF(f);
    return f;
}

static PyObject *item_get_end(Item *it, void *closure) {
    if (!it->has_end)
        Py_RETURN_NONE;
    return PyLong_FromLongLong(it->end_ns);
}

static PyGetSetDef item_getset[] = {
    {"frame", (getter)item_get_frame, NULL, "the Frame record", NULL},
    {"end_ns", (getter)item_get_end, NULL, "end of its transmission (ns), None until sent", NULL},
    {NULL},
};

static PyTypeObject ItemType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "wheelleg.hil.fast._framecore.Queued",
    .tp_basicsize = sizeof(Item),
    .tp_dealloc = (destructor)item_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "One frame on a wire of the compiled record path (the handle of a received frame).",
    .tp_getset = item_getset,
};

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

static int grow(Item ***v, Py_ssize_t *cap, Py_ssize_t need) {
    if (need <= *cap)
        return 0;
    Py_ssize_t cap2 = *cap ? *cap * 2 : 64;
    while (cap2 < need)
        cap2 *= 2;
    Item **nv = PyMem_Realloc(*v, cap2 * sizeof(Item *));
    if (!nv) {
        PyErr_NoMemory();
        return -1;
    }
    *v = nv;
    *cap = cap2;
    return 0;
}

/* the heap takes the caller's reference */
static int heap_push(Heap *h, Item *it, int (*less)(const Item *, const Item *)) {
    if (grow(&h->v, &h->cap, h->n + 1) < 0)
        return -1;
    Py_ssize_t i = h->n++;
    while (i > 0) {
        Py_ssize_t parent = (i - 1) / 2;
        if (!less(it, h->v[parent]))
            break;
        h->v[i] = h->v[parent];
        i = parent;
    }
    h->v[i] = it;
    return 0;
}

/* the caller gets the heap's reference */
static Item *heap_pop(Heap *h, int (*less)(const Item *, const Item *)) {
    Item *top = h->v[0], *last = h->v[--h->n];
    Py_ssize_t i = 0, n = h->n;
    while (1) {
        Py_ssize_t c = 2 * i + 1;
        if (c >= n)
            break;
        if (c + 1 < n && less(h->v[c + 1], h->v[c]))
            c++;
        if (!less(h->v[c], last))
            break;
        h->v[i] = h->v[c];
        i = c;
    }
    if (n > 0)
        h->v[i] = last;
    return top;
}

static int fifo_push(Fifo *q, Item *it) {
    if (q->head > 0 && q->head + q->n == q->cap) {  /* slide to the front */
        memmove(q->v, q->v + q->head, q->n * sizeof(Item *));
        q->head = 0;
    }
    if (grow(&q->v, &q->cap, q->head + q->n + 1) < 0)
        return -1;
    q->v[q->head + q->n++] = it;
    return 0;
}

static inline Item *fifo_front(Fifo *q) { return q->n ? q->v[q->head] : NULL; }

static inline Item *fifo_pop(Fifo *q) {
    Item *it = q->v[q->head++];
    if (--q->n == 0)
        q->head = 0;
    return it;
}

static void heap_clear(Heap *h) {
    for (Py_ssize_t i = 0; i < h->n; i++)
        Py_DECREF(h->v[i]);
    PyMem_Free(h->v);
    h->v = NULL;
    h->n = h->cap = 0;
}

static void fifo_clear(Fifo *q) {
    for (Py_ssize_t i = 0; i < q->n; i++)
        Py_DECREF(q->v[q->head + i]);
    PyMem_Free(q->v);
    q->v = NULL;
    q->n = q->head = q->cap = 0;
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

static PyObject *s_now_ns, *s_t_ns, *s_arbitration_id, *s_is_extended_id, *s_is_error_frame,
    *s_is_remote_frame, *s_is_fd, *s_data, *s_dlc, *s_empty, *s_channel, *s_is_extended, *s_is_error,
    *s_is_remote, *s_fd_flags;

static void wire_clear(Wire *w) {
    fifo_clear(&w->controller);
    heap_clear(&w->timed);
    heap_clear(&w->eligible);
    fifo_clear(&w->sent);
    Py_CLEAR(w->last);
}

static int core_add_channel(Core *c, PyObject *name) {
    if (c->nwires == c->capwires) {
        int cap = c->capwires ? c->capwires * 2 : 4;
        Wire *nw = PyMem_Realloc(c->wires, cap * sizeof(Wire));
        if (!nw) {
            PyErr_NoMemory();
            return -1;
        }
        c->wires = nw;
        c->capwires = cap;
    }
    PyObject *idx = PyLong_FromLong(c->nwires);
    if (!idx || PyDict_SetItem(c->index, name, idx) < 0 || PyList_Append(c->channels, name) < 0) {
        Py_XDECREF(idx);
        return -1;
    }
    Py_DECREF(idx);
    memset(&c->wires[c->nwires], 0, sizeof(Wire));
    return c->nwires++;
}

static int core_channel(Core *c, PyObject *name) {
    PyObject *idx = PyDict_GetItemWithError(c->index, name);
    if (idx)
        return (int)PyLong_AsLong(idx);
    if (PyErr_Occurred())
        return -1;
    return core_add_channel(c, name);
}

/* wire_order.BusWire._queued: counts, key, ready time; the wire's last frame */
static void wire_queued(Wire *w, Item *it, int64_t ready_ns, int has_ready, int is_error, int64_t prio) {
    w->busy_ns_total += it->wire_ns;
    w->frames_total += 1;
    it->seq = ++w->seq;
    it->prio = is_error ? -1 : prio;
    it->ready_ns = ready_ns;
    it->has_ready = has_ready;
    Py_INCREF(it);
    Py_XSETREF(w->last, it);
}

static int wire_send(Core *c, Wire *w, Item *it, int64_t start_ns) {
    /* takes the caller's reference to ``it`` into ``sent`` */
    it->end_ns = w->free_ns = start_ns + it->wire_ns;
    it->has_end = 1;
    if (fifo_push(&w->sent, it) < 0) {
        Py_DECREF(it);
        return -1;
    }
    Item *reply = it->reply_head;
    it->reply_head = it->reply_tail = NULL;  /* the list's references move to the heaps */
    while (reply) {
        Item *next = reply->reply_next;
        reply->reply_next = NULL;
        reply->ready_ns = it->end_ns + reply->delay_ns;
        reply->has_ready = 1;
        Wire *rw = &c->wires[reply->wire];
        rw->unresolved--;
        if (heap_push(&rw->timed, reply, timed_less) < 0) {
            Py_DECREF(reply);
            Py_XDECREF(next);
            return -1;
        }
        reply = next;
    }
    return 0;
}

/* wire_order.BusWire.run_until; until_none: send every frame that waits */
static int wire_run_until(Core *c, Wire *w, int64_t now_ns, int until_none) {
    while (1) {
        int64_t start = w->free_ns;
        while (w->timed.n && w->timed.v[0]->ready_ns <= start)
            if (heap_push(&w->eligible, heap_pop(&w->timed, timed_less), key_less) < 0)
                return -1;
        Item *front = fifo_front(&w->controller);
        Item *head = (front && front->ready_ns <= start) ? front : NULL;
        if (!w->eligible.n && !head) {  /* idle until the first frame is queued */
            if (w->timed.n) {
                start = w->timed.v[0]->ready_ns;
                if (front && front->ready_ns < start)
                    start = front->ready_ns;
            } else if (front) {
                start = front->ready_ns;
            } else {
                return 0;
            }
            if (!until_none && start >= now_ns)
                return 0;
            while (w->timed.n && w->timed.v[0]->ready_ns <= start)
                if (heap_push(&w->eligible, heap_pop(&w->timed, timed_less), key_less) < 0)
                    return -1;
            head = (front && front->ready_ns <= start) ? front : NULL;
        } else if (!until_none && start >= now_ns) {
            return 0;
        }
        Item *it;
        if (head && (!w->eligible.n || key_less(head, w->eligible.v[0])))
            it = fifo_pop(&w->controller);
        else
            it = heap_pop(&w->eligible, key_less);
        if (wire_send(c, w, it, start) < 0)
            return -1;
    }
}

/* wire_order.BusWire.queue: a device's frame (``answers``: the received frame it replies to) */
static int wire_queue(Core *c, Wire *w, Item *it, int64_t ready_ns, Item *answers, int is_error, int64_t prio) {
    int64_t delay = c->response_ns;
    if (is_error && w->last) {
        answers = w->last;
        delay = 0;
    }
    if (!answers) {
        wire_queued(w, it, ready_ns, 1, is_error, prio);
        Py_INCREF(it);
        return heap_push(&w->timed, it, timed_less) < 0 ? (Py_DECREF(it), -1) : 0;
    }
    Py_INCREF(answers);  /* ``w->last`` may be replaced by this frame */
    wire_queued(w, it, 0, 0, is_error, prio);
    int rc = 0;
    if (answers->has_end) {
        it->ready_ns = answers->end_ns + delay;
        it->has_ready = 1;
        Py_INCREF(it);
        if (heap_push(&w->timed, it, timed_less) < 0) {
            Py_DECREF(it);
            rc = -1;
        }
    } else {
        it->delay_ns = delay;
        Py_INCREF(it);
        if (answers->reply_tail)
            answers->reply_tail->reply_next = it;
        else
            answers->reply_head = it;
        answers->reply_tail = it;
        w->unresolved++;
    }
    Py_DECREF(answers);
    return rc;
}

static int64_t frame_prio(int64_t id, int extended, int remote) {
    if (extended)
        return ((id >> 18) << 21) | (1 << 20) | ((id & 0x3FFFF) << 1) | remote;
    return (id << 21) | remote;
}

/* ------------------------------------------------------------------------------------------ */
/* Core: noting frames, settling them (Recorder.sent / received / settle / _emit)               */

static void core_clear_noted(Core *c, Py_ssize_t from, Py_ssize_t to) {
    for (Py_ssize_t i = from; i < to; i++) {
        Py_CLEAR(c->noted[i].item);
        Py_CLEAR(c->noted[i].answers);
    }
}

static int core_traverse(Core *c, visitproc visit, void *arg) {
    Py_VISIT(c->frame_type);
    Py_VISIT(c->clock);
    Py_VISIT(c->on_load);
    Py_VISIT(c->on_full);
    Py_VISIT(c->wire_ns_py);
    for (int i = 0; i < 4; i++)
        Py_VISIT(c->defaults[i]);
    return 0;
}

static int core_clear(Core *c) {
    core_clear_noted(c, 0, c->nnoted);
    c->nnoted = 0;
    for (int i = 0; i < c->nwires; i++)
        wire_clear(&c->wires[i]);
    c->nwires = 0;
    Py_CLEAR(c->frame_type);
    Py_CLEAR(c->clock);
    Py_CLEAR(c->on_load);
    Py_CLEAR(c->on_full);
    Py_CLEAR(c->wire_ns_py);
    for (int i = 0; i < 4; i++)
        Py_CLEAR(c->defaults[i]);
    return 0;
}

static void core_dealloc(Core *c) {
    PyObject_GC_UnTrack(c);
    core_clear(c);
    PyMem_Free(c->wires);
    PyMem_Free(c->noted);
    Py_CLEAR(c->channels);
    Py_CLEAR(c->index);
    Py_TYPE(c)->tp_free((PyObject *)c);
}

/* The Frame class's slot offsets (``__slots__`` member descriptors, in the dataclass's field order) and
 * the defaults an instance made with the 10 leading fields gets; left 0 when the class is not laid out
 * so (then frames are made by calling it). */
static int core_find_slots(Core *c) {
    static const char *names[13] = {"t_ns", "channel", "arbitration_id", "is_extended", "data", "dlc", "bus",
                                    "is_error", "is_remote", "is_fd", "fd_flags", "direction", "line_no"};
    PyTypeObject *type = (PyTypeObject *)c->frame_type;
    if (!PyType_Check(c->frame_type) || type->tp_init == NULL || type->tp_alloc == NULL)
        return 0;
    Py_ssize_t slot[13];
    for (int i = 0; i < 13; i++) {
        PyObject *d = PyDict_GetItemString(type->tp_dict, names[i]);
        if (!d || Py_TYPE(d) != &PyMemberDescr_Type)
            return 0;
        PyMemberDef *m = ((PyMemberDescrObject *)d)->d_member;
        if (m->type != T_OBJECT_EX || (m->flags & READONLY))
            return 0;
        slot[i] = m->offset;
    }
    PyObject *empty = PyBytes_FromStringAndSize("", 0);
    PyObject *probe = empty ? PyObject_CallFunction(c->frame_type, "iOiOOiOOOO", 0, s_empty, 0, Py_False, empty, 0,
                                                    s_empty, Py_False, Py_False, Py_False) : NULL;
    Py_XDECREF(empty);
    if (!probe) {
        PyErr_Clear();
        return 0;
    }
    int defaulted[4] = {6, 10, 11, 12};  /* bus (as given), fd_flags, direction, line_no (the class's) */
    for (int i = 0; i < 4; i++) {
        PyObject *v = *(PyObject **)((char *)probe + slot[defaulted[i]]);
        if (!v) {
            Py_DECREF(probe);
            return 0;
        }
        Py_INCREF(v);
        Py_XSETREF(c->defaults[i], v);
    }
    Py_DECREF(probe);
    memcpy(c->slot, slot, sizeof(slot));
    return 0;
}

static int core_init(Core *c, PyObject *args, PyObject *kw) {
    static char *names[] = {"channels", "frame_type", "clock", "bitrate", "sync_id", "response_ns",
                            "wire_ns", "on_load", "on_full", "batch", NULL};
    PyObject *channels, *frame_type, *clock, *wire_ns_py, *on_load, *on_full;
    long long bitrate, sync_id, response_ns;
    Py_ssize_t batch;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "OOOLLLOOOn", names, &channels, &frame_type, &clock, &bitrate,
                                     &sync_id, &response_ns, &wire_ns_py, &on_load, &on_full, &batch))
        return -1;
    if (bitrate <= 0) {
        PyErr_SetString(PyExc_ValueError, "bitrate must be > 0");
        return -1;
    }
    c->channels = PyList_New(0);
    c->index = PyDict_New();
    if (!c->channels || !c->index)
        return -1;
    Py_INCREF(frame_type); c->frame_type = frame_type;
    if (core_find_slots(c) < 0)
        return -1;
    Py_INCREF(clock); c->clock = clock;
    Py_INCREF(wire_ns_py); c->wire_ns_py = wire_ns_py;
    Py_INCREF(on_load); c->on_load = on_load;
    Py_INCREF(on_full); c->on_full = on_full;
    c->bitrate = bitrate;
    c->sync_id = sync_id;
    c->response_ns = response_ns;
    c->batch = batch < 1 ? 1 : batch;
    c->run_to_ns = -1;
    c->load_due_ns = INT64_MAX;
    PyObject *it = PyObject_GetIter(channels), *name;
    if (!it)
        return -1;
    while ((name = PyIter_Next(it))) {
        int rc = core_add_channel(c, name);
        if (rc >= 0)
            c->wires[rc].listed = 1;
        Py_DECREF(name);
        if (rc < 0) {
            Py_DECREF(it);
            return -1;
        }
    }
    Py_DECREF(it);
    return PyErr_Occurred() ? -1 : 0;
}

static int attr_true(PyObject *obj, PyObject *name, PyObject **out) {
    *out = PyObject_GetAttr(obj, name);
    if (!*out)
        return -1;
    return PyObject_IsTrue(*out);
}

/* The Frame of ``msg`` on channel ``ch`` (recorder._frame) and its wire-model entry. */
static Item *core_item(Core *c, int ch, PyObject *msg) {
    PyObject *id_o = NULL, *ext_o = NULL, *err_o = NULL, *rtr_o = NULL, *fd_o = NULL, *data_o = NULL,
             *dlc_o = NULL, *payload = NULL;
    Item *it = NULL;
    int ext, err, rtr;
    if (!(id_o = PyObject_GetAttr(msg, s_arbitration_id)) || (ext = attr_true(msg, s_is_extended_id, &ext_o)) < 0
        || (err = attr_true(msg, s_is_error_frame, &err_o)) < 0 || (rtr = attr_true(msg, s_is_remote_frame, &rtr_o)) < 0
        || !(fd_o = PyObject_GetAttr(msg, s_is_fd)) || !(data_o = PyObject_GetAttr(msg, s_data))
        || !(dlc_o = PyObject_GetAttr(msg, s_dlc)))
        goto done;
    Py_ssize_t dlc = PyNumber_AsSsize_t(dlc_o, PyExc_OverflowError), len = PyObject_Length(data_o);
    if ((dlc == -1 || len == -1) && PyErr_Occurred())
        goto done;
    if (len <= dlc) {  /* the payload up to the DLC; sliced only when longer */
        payload = PyBytes_FromObject(data_o);
    } else {
        PyObject *cut = PySequence_GetSlice(data_o, 0, dlc);
        payload = cut ? PyBytes_FromObject(cut) : NULL;
        Py_XDECREF(cut);
    }
    if (!payload)
        goto done;
    PyObject *name = PyList_GET_ITEM(c->channels, ch);
    PyObject *zero = PyLong_FromLong(0);
    if (!zero)
        goto done;
    PyObject *frame;
    if (c->slot[0]) {  /* the Frame the class's __init__ makes, slot by slot */
        PyTypeObject *type = (PyTypeObject *)c->frame_type;
        frame = type->tp_alloc(type, 0);
        if (frame) {
            PyObject *values[13] = {zero, name, id_o, ext_o, payload, dlc_o, c->defaults[0], err_o, rtr_o, fd_o,
                                    c->defaults[1], c->defaults[2], c->defaults[3]};
            for (int i = 0; i < 13; i++) {
                Py_INCREF(values[i]);
                *(PyObject **)((char *)frame + c->slot[i]) = values[i];
            }
        }
    } else {
        PyObject *argv[10] = {zero, name, id_o, ext_o, payload, dlc_o, s_empty, err_o, rtr_o, fd_o};
        frame = PyObject_Vectorcall(c->frame_type, argv, 10, NULL);
    }
    Py_DECREF(zero);
    if (!frame)
        goto done;
    it = PyObject_New(Item, &ItemType);
    if (!it) {
        Py_DECREF(frame);
        goto done;
    }
    it->frame = frame;
    it->reply_head = it->reply_tail = it->reply_next = NULL;
    it->has_end = it->has_ready = 0;
    it->delay_ns = it->ready_ns = it->end_ns = it->prio = it->seq = 0;
    it->wire = ch;
    /* its wire time: busload.wire_ns; out of the common range Python's own (and its errors) */
    long long id = PyLong_AsLongLong(id_o);
    if (id == -1 && PyErr_Occurred())
        PyErr_Clear();
    else if (id >= 0 && id <= (ext ? 0x1FFFFFFF : 0x7FF) && PyBytes_GET_SIZE(payload) <= 64) {
        it->wire_ns = frame_bits((uint32_t)id, ext, (unsigned char *)PyBytes_AS_STRING(payload),
                                 PyBytes_GET_SIZE(payload)) * 1000000000LL / c->bitrate;
        it->prio = frame_prio(id, ext, rtr);
        it->is_error = err;
        it->is_sync = id == c->sync_id && !ext && !err;
        goto done;
    }
    {
        PyObject *bitrate = PyLong_FromLongLong(c->bitrate);
        PyObject *ns = bitrate ? PyObject_CallFunctionObjArgs(c->wire_ns_py, id_o, ext_o, payload, bitrate, NULL) : NULL;
        Py_XDECREF(bitrate);
        long long v = ns ? PyLong_AsLongLong(ns) : -1;
        Py_XDECREF(ns);
        if (PyErr_Occurred()) {
            Py_CLEAR(it);
            goto done;
        }
        it->wire_ns = v;
        /* arbitration_priority with Python ints (an id beyond 29 bits sorts by Python's rules): clamp */
        it->prio = id < 0 ? 0 : frame_prio(id, ext, rtr);
        it->is_error = err;
        it->is_sync = id == c->sync_id && !ext && !err;
    }
done:
    Py_XDECREF(id_o); Py_XDECREF(ext_o); Py_XDECREF(err_o); Py_XDECREF(rtr_o); Py_XDECREF(fd_o);
    Py_XDECREF(data_o); Py_XDECREF(dlc_o); Py_XDECREF(payload);
    return it;
}

static int core_note(Core *c, int ch, Item *it, Item *answers, int received) {
    PyObject *now = PyObject_GetAttr(c->clock, s_now_ns);
    if (!now)
        return -1;
    long long now_ns = PyLong_AsLongLong(now);
    Py_DECREF(now);
    if (now_ns == -1 && PyErr_Occurred())
        return -1;
    if (c->nnoted == c->capnoted) {
        Py_ssize_t cap = c->capnoted ? c->capnoted * 2 : 256;
        Noted *nn = PyMem_Realloc(c->noted, cap * sizeof(Noted));
        if (!nn) {
            PyErr_NoMemory();
            return -1;
        }
        c->noted = nn;
        c->capnoted = cap;
    }
    Noted *n = &c->noted[c->nnoted++];
    n->now_ns = now_ns;
    n->channel = ch;
    n->received = received;
    Py_INCREF(it);
    n->item = it;
    Py_XINCREF(answers);
    n->answers = answers;
    if (c->nnoted >= c->batch) {
        PyObject *r = PyObject_CallNoArgs(c->on_full);
        if (!r)
            return -1;
        Py_DECREF(r);
    }
    return 0;
}

static PyObject *core_sent(Core *c, PyObject *const *args, Py_ssize_t nargs, PyObject *kwnames) {
    Py_ssize_t nkw = kwnames ? PyTuple_GET_SIZE(kwnames) : 0;
    PyObject *answers_o = nargs == 3 ? args[2] : Py_None;
    if (nkw == 1 && nargs == 2 && PyUnicode_CompareWithASCIIString(PyTuple_GET_ITEM(kwnames, 0), "answers") == 0)
        answers_o = args[2];
    else if (nkw || nargs < 2 || nargs > 3) {
        PyErr_SetString(PyExc_TypeError, "sent(channel, msg, answers=None)");
        return NULL;
    }
    Item *answers = NULL;
    if (answers_o != Py_None) {
        if (Py_TYPE(answers_o) != &ItemType) {
            PyErr_SetString(PyExc_TypeError, "answers: a handle from received()");
            return NULL;
        }
        answers = (Item *)answers_o;
    }
    int ch = core_channel(c, args[0]);
    if (ch < 0)
        return NULL;
    Item *it = core_item(c, ch, args[1]);
    if (!it)
        return NULL;
    int rc = core_note(c, ch, it, answers, 0);
    Py_DECREF(it);
    if (rc < 0)
        return NULL;
    Py_RETURN_NONE;
}

static PyObject *core_received(Core *c, PyObject *const *args, Py_ssize_t nargs) {
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "received(channel, msg)");
        return NULL;
    }
    int ch = core_channel(c, args[0]);
    if (ch < 0)
        return NULL;
    Item *it = core_item(c, ch, args[1]);
    if (!it)
        return NULL;
    if (core_note(c, ch, it, NULL, 1) < 0) {
        Py_DECREF(it);
        return NULL;
    }
    return (PyObject *)it;
}

typedef struct { int64_t t; Py_ssize_t pos; PyObject *frame; } Out;

static int out_cmp(const void *a, const void *b) {
    const Out *x = a, *y = b;
    if (x->t != y->t)
        return x->t < y->t ? -1 : 1;
    return x->pos < y->pos ? -1 : (x->pos > y->pos);
}

/* Recorder._emit: every sent frame no later frame can precede (all: every one), onto ``out`` in time
 * order (ties: channel order); each frame's t_ns set to the end of its transmission. */
static int core_emit(Core *c, int64_t now_ns, int all, PyObject *out) {
    int64_t settled = INT64_MAX;
    if (!all)
        for (int i = 0; i < c->nwires; i++) {
            if (!c->wires[i].listed)
                continue;
            int64_t free = c->wires[i].free_ns > now_ns ? c->wires[i].free_ns : now_ns;
            if (free < settled)
                settled = free;
        }
    Py_ssize_t count = 0;
    int buses = 0;
    for (int i = 0; i < c->nwires; i++) {
        Fifo *q = &c->wires[i].sent;
        Py_ssize_t k = 0;
        while (k < q->n && (all || q->v[q->head + k]->end_ns <= settled))
            k++;
        count += k;
        buses += k > 0;
    }
    if (!count)
        return 0;
    Out *tmp = PyMem_Malloc(count * sizeof(Out));
    if (!tmp) {
        PyErr_NoMemory();
        return -1;
    }
    Py_ssize_t at = 0;
    int rc = 0;
    for (int i = 0; i < c->nwires; i++) {
        Fifo *q = &c->wires[i].sent;
        while (q->n && (all || fifo_front(q)->end_ns <= settled)) {
            Item *it = fifo_pop(q);
            tmp[at].t = it->end_ns;
            tmp[at].pos = at;
            tmp[at].frame = it->frame;
            Py_INCREF(it->frame);
            PyObject *t = PyLong_FromLongLong(it->end_ns);
            if (t && c->slot[0]) {  /* t_ns's slot, as setting the attribute does */
                PyObject **at = (PyObject **)((char *)it->frame + c->slot[0]);
                Py_XSETREF(*at, t);
            } else if (!t || PyObject_SetAttr(it->frame, s_t_ns, t) < 0) {
                rc = -1;
            }
            if (!c->slot[0])
                Py_XDECREF(t);
            Py_DECREF(it);
            at++;
        }
    }
    if (buses > 1 && count > 1)
        qsort(tmp, count, sizeof(Out), out_cmp);
    for (Py_ssize_t i = 0; i < count; i++) {
        if (rc == 0 && PyList_Append(out, tmp[i].frame) < 0)
            rc = -1;
        Py_DECREF(tmp[i].frame);
    }
    PyMem_Free(tmp);
    return rc;
}

static int core_load(Core *c, int64_t now_ns) {
    PyObject *r = PyObject_CallFunction(c->on_load, "L", (long long)now_ns);
    if (!r)
        return -1;
    long long due = PyLong_AsLongLong(r);
    Py_DECREF(r);
    if (due == -1 && PyErr_Occurred())
        return -1;
    c->load_due_ns = due;
    return 0;
}

/* Recorder.settle: the oldest ``limit`` noted frames (-1: all) on their wires; the settled frames */
static PyObject *core_settle(Core *c, PyObject *args) {
    Py_ssize_t limit = -1;
    if (!PyArg_ParseTuple(args, "|n", &limit))
        return NULL;
    PyObject *out = PyList_New(0);
    if (!out)
        return NULL;
    Py_ssize_t take = (limit >= 0 && limit < c->nnoted) ? limit : c->nnoted;
    Py_ssize_t done = 0;
    int rc = 0;
    for (; done < take && rc == 0; done++) {
        Noted *n = &c->noted[done];
        int64_t now_ns = n->now_ns;
        if (now_ns >= c->load_due_ns && core_load(c, now_ns) < 0) {
            rc = -1;
            break;
        }
        Wire *w = &c->wires[n->channel];
        w->listed = 1;
        Item *it = n->item;
        int is_error = it->is_error, is_sync = it->is_sync, emit = 0;
        int64_t prio = it->prio;
        c->frames++;
        if (n->received) {
            wire_queued(w, it, now_ns > c->tick_ns ? now_ns : c->tick_ns, 1, is_error, prio);
            Py_INCREF(it);
            rc = fifo_push(&w->controller, it);
            if (rc < 0)
                Py_DECREF(it);
        } else if (is_sync) {  /* wire_order.BusWire.barrier */
            if (wire_run_until(c, w, 0, 1) < 0) {
                rc = -1;
                break;
            }
            wire_queued(w, it, now_ns, 1, 0, prio);
            Py_INCREF(it);
            rc = wire_send(c, w, it, now_ns > w->free_ns ? now_ns : w->free_ns);
            if (w->free_ns > c->tick_ns)
                c->tick_ns = w->free_ns;
            emit = 1;
        } else {
            rc = wire_queue(c, w, it, now_ns, n->answers, is_error, prio);
        }
        if (rc < 0)
            break;
        if (now_ns > c->run_to_ns) {
            for (int i = 0; i < c->nwires && rc == 0; i++)
                rc = wire_run_until(c, &c->wires[i], now_ns, 0);
            c->run_to_ns = now_ns;
            emit = 1;
        }
        if (rc == 0 && emit)
            rc = core_emit(c, now_ns, 0, out);
    }
    if (rc < 0)
        done = done < take ? done + 1 : take;  /* the frame that failed is dropped with the error */
    core_clear_noted(c, 0, done);
    memmove(c->noted, c->noted + done, (c->nnoted - done) * sizeof(Noted));
    c->nnoted -= done;
    if (rc < 0) {
        Py_DECREF(out);
        return NULL;
    }
    return out;
}

/* Recorder.stop's wire part: every frame still queued sent; every sent frame, in time order */
static PyObject *core_finish(Core *c, PyObject *unused) {
    PyObject *out = PyList_New(0);
    if (!out)
        return NULL;
    for (int i = 0; i < c->nwires; i++)
        if (wire_run_until(c, &c->wires[i], 0, 1) < 0) {
            Py_DECREF(out);
            return NULL;
        }
    if (core_emit(c, 0, 1, out) < 0) {
        Py_DECREF(out);
        return NULL;
    }
    return out;
}

static PyObject *core_set_load_due(Core *c, PyObject *arg) {
    long long due = PyLong_AsLongLong(arg);
    if (due == -1 && PyErr_Occurred())
        return NULL;
    c->load_due_ns = due;
    Py_RETURN_NONE;
}

/* (free_ns, busy_ns_total, frames_total, waiting) of the wire of ``channel`` */
static PyObject *core_wire_state(Core *c, PyObject *name) {
    int ch = core_channel(c, name);
    if (ch < 0)
        return NULL;
    Wire *w = &c->wires[ch];
    w->listed = 1;
    return Py_BuildValue("LLLn", (long long)w->free_ns, (long long)w->busy_ns_total, (long long)w->frames_total,
                         w->timed.n + w->eligible.n + w->unresolved);
}

static PyObject *core_pending(Core *c, PyObject *unused) { return PyLong_FromSsize_t(c->nnoted); }

static PyObject *core_get_frames(Core *c, void *closure) { return PyLong_FromLongLong(c->frames); }

static PyObject *core_get_channels(Core *c, void *closure) {
    PyObject *out = PyList_New(0);
    for (int i = 0; out && i < c->nwires; i++)
        if (c->wires[i].listed && PyList_Append(out, PyList_GET_ITEM(c->channels, i)) < 0)
            Py_CLEAR(out);
    return out;
}

static PyMethodDef core_methods[] = {
    {"sent", (PyCFunction)(void (*)(void))core_sent, METH_FASTCALL | METH_KEYWORDS,
     "sent(channel, msg, answers=None): note a frame the plant side put on ``channel``."},
    {"received", (PyCFunction)(void (*)(void))core_received, METH_FASTCALL,
     "received(channel, msg): note a frame the plant side took off ``channel``; its handle."},
    {"settle", (PyCFunction)core_settle, METH_VARARGS,
     "settle(limit=-1): the oldest ``limit`` noted frames (-1: all) on their wires; the settled Frames."},
    {"finish", (PyCFunction)core_finish, METH_NOARGS, "every queued frame sent; every sent Frame in time order."},
    {"set_load_due", (PyCFunction)core_set_load_due, METH_O, "the clock time (ns) of the next load sample."},
    {"wire_state", (PyCFunction)core_wire_state, METH_O, "(free_ns, busy_ns_total, frames_total, waiting)."},
    {"pending", (PyCFunction)core_pending, METH_NOARGS, "frames noted and not settled."},
    {NULL},
};

static PyGetSetDef core_getset[] = {
    {"frames", (getter)core_get_frames, NULL, "frames settled", NULL},
    {"channels", (getter)core_get_channels, NULL, "the listed channels' names, in tie-break order", NULL},
    {NULL},
};

static PyTypeObject CoreType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "wheelleg.hil.fast._framecore.RecordCore",
    .tp_basicsize = sizeof(Core),
    .tp_dealloc = (destructor)core_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC,
    .tp_doc = "The recorder's wire models and noted frames (hil/bus/recorder.py's compiled path).",
    .tp_traverse = (traverseproc)core_traverse,
    .tp_clear = (inquiry)core_clear,
    .tp_methods = core_methods,
    .tp_getset = core_getset,
    .tp_init = (initproc)core_init,
    .tp_new = PyType_GenericNew,
};

/* ------------------------------------------------------------------------------------------ */
/* Frame fields read for the sinks                                                              */

typedef struct {
    long long t_ns, id;
    int ext;
    const char *data;
    Py_ssize_t len;
    PyObject *channel, *data_o;  /* borrowed from the caller's references below */
    PyObject *refs[8];
} Fields;

static void fields_release(Fields *f) {
    for (int i = 0; i < 8; i++)
        Py_CLEAR(f->refs[i]);
}

/* 1: a plain classic data frame (not error, remote or FD, fd_flags 0, bytes payload <= 8, int time and
 * id, the channel a str); 0: anything else; -1: an error. */
static int plain_fields(PyObject *frame, Fields *f) {
    memset(f->refs, 0, sizeof(f->refs));
    f->t_ns = f->id = 0;
    f->len = 0;
    PyObject *names[8] = {s_t_ns, s_channel, s_arbitration_id, s_is_extended, s_data, s_is_error, s_is_remote, s_is_fd};
    for (int i = 0; i < 8; i++)
        if (!(f->refs[i] = PyObject_GetAttr(frame, names[i])))
            return -1;
    for (int i = 5; i < 8; i++)  /* error, remote, FD */
        if (f->refs[i] != Py_False)
            return 0;
    if (!PyLong_CheckExact(f->refs[0]) || !PyLong_CheckExact(f->refs[2]) || !PyBytes_CheckExact(f->refs[4])
        || !PyUnicode_CheckExact(f->refs[1]) || (f->refs[3] != Py_True && f->refs[3] != Py_False))
        return 0;
    f->t_ns = PyLong_AsLongLong(f->refs[0]);
    f->id = PyLong_AsLongLong(f->refs[2]);
    if (PyErr_Occurred()) {
        PyErr_Clear();
        return 0;
    }
    f->ext = f->refs[3] == Py_True;
    f->channel = f->refs[1];
    f->data_o = f->refs[4];
    f->data = PyBytes_AS_STRING(f->data_o);
    f->len = PyBytes_GET_SIZE(f->data_o);
    return f->len <= 8;
}

/* candump's lines of ``frames`` from ``start`` while each is a plain classic data frame on a channel in
 * ``checked``, its time + ``epoch_ns`` >= 0 and its id in range: (text, index of the first frame not
 * written). The Python writer writes the rest (its checks, the other forms) and calls again. */
static PyObject *candump_lines(PyObject *self, PyObject *args) {
    PyObject *frames, *checked;
    long long epoch;
    Py_ssize_t start;
    if (!PyArg_ParseTuple(args, "OLO!n", &frames, &epoch, &PySet_Type, &checked, &start))
        return NULL;
    PyObject *seq = PySequence_Fast(frames, "frames: a sequence");
    if (!seq)
        return NULL;
    Py_ssize_t n = PySequence_Fast_GET_SIZE(seq), i = start;
    size_t cap = 4096, used = 0;
    char *buf = PyMem_Malloc(cap);
    if (!buf) {
        Py_DECREF(seq);
        return PyErr_NoMemory();
    }
    static const char hex[] = "0123456789ABCDEF";
    for (; i < n; i++) {
        Fields f;
        int plain = plain_fields(PySequence_Fast_GET_ITEM(seq, i), &f);
        if (plain < 0) {
            fields_release(&f);
            goto fail;
        }
        long long t;
        if (!plain || f.id < 0 || f.id > (f.ext ? 0x1FFFFFFF : 0x7FF) || __builtin_add_overflow(f.t_ns, epoch, &t)
            || t < 0) {
            fields_release(&f);
            break;
        }
        int known = PySet_Contains(checked, f.channel);
        Py_ssize_t clen;
        const char *cname = known > 0 ? PyUnicode_AsUTF8AndSize(f.channel, &clen) : NULL;
        if (!cname) {
            fields_release(&f);
            if (known < 0 || (known > 0 && PyErr_Occurred()))
                goto fail;
            break;  /* a channel not checked yet */
        }
        size_t need = used + 40 + (size_t)clen + 2 * (size_t)f.len;
        if (need > cap) {
            while (cap < need)
                cap *= 2;
            char *nb = PyMem_Realloc(buf, cap);
            if (!nb) {
                fields_release(&f);
                PyErr_NoMemory();
                goto fail;
            }
            buf = nb;
        }
        char *p = buf + used;
        p += sprintf(p, "(%010lld.%06lld) ", t / 1000000000LL, t % 1000000000LL / 1000LL);
        memcpy(p, cname, clen);
        p += clen;
        p += sprintf(p, f.ext ? " %08llX#" : " %03llX#", f.id);
        for (Py_ssize_t k = 0; k < f.len; k++) {
            unsigned char b = (unsigned char)f.data[k];
            *p++ = hex[b >> 4];
            *p++ = hex[b & 15];
        }
        *p++ = '\n';
        used = p - buf;
        fields_release(&f);
    }
    Py_DECREF(seq);
    PyObject *text = PyUnicode_DecodeASCII(buf, used, NULL);
    PyMem_Free(buf);
    if (!text)
        return NULL;
    return Py_BuildValue("(Nn)", text, i);
fail:
    Py_DECREF(seq);
    PyMem_Free(buf);
    return NULL;
}

/* can_batch.pack for frames that are all plain classic data frames with times and ids in range (the
 * rig's own): the same bytes; None for anything else (the Python packer then packs or raises). */
static PyObject *pack_plain(PyObject *self, PyObject *frames) {
    PyObject *seq = PySequence_Fast(frames, "frames: a sequence");
    if (!seq)
        return NULL;
    Py_ssize_t n = PySequence_Fast_GET_SIZE(seq);
    if (n == 0 || n > 0xFFFFFFFFLL) {
        Py_DECREF(seq);
        Py_RETURN_NONE;
    }
    unsigned char *cols = PyMem_Malloc(n * (8 + 3 + 8));  /* gaps+ids (8), flags, dlc, length (3), data (8) */
    if (!cols) {
        Py_DECREF(seq);
        return PyErr_NoMemory();
    }
    uint32_t *gaps = (uint32_t *)cols, *ids = gaps + n;  /* host order: written little-endian below */
    unsigned char *flags = cols + 8 * n, *dlcs = flags + n, *lens = dlcs + n, *data = lens + n;
    size_t total = 0;
    long long prev = 0;
    PyObject *result = NULL;
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *frame = PySequence_Fast_GET_ITEM(seq, i);
        Fields f;
        int plain = plain_fields(frame, &f);
        PyObject *dlc_o = plain > 0 ? PyObject_GetAttr(frame, s_dlc) : NULL;
        PyObject *fd_flags = plain > 0 && dlc_o ? PyObject_GetAttr(frame, s_fd_flags) : NULL;
        long long dlc = dlc_o && PyLong_CheckExact(dlc_o) ? PyLong_AsLongLong(dlc_o) : -1;
        int fd0 = fd_flags && PyLong_CheckExact(fd_flags) && PyLong_AsLong(fd_flags) == 0;
        long long gap = i ? f.t_ns - prev : 0;
        int ok = plain > 0 && fd0 && dlc >= 0 && dlc <= 255 && f.id >= 0 && f.id <= 0xFFFFFFFFLL
                 && gap >= 0 && gap <= 0xFFFFFFFFLL;
        if (ok) {
            gaps[i] = (uint32_t)gap;
            ids[i] = (uint32_t)f.id;
            flags[i] = (unsigned char)f.ext;
            dlcs[i] = (unsigned char)dlc;
            lens[i] = (unsigned char)f.len;
            memcpy(data + total, f.data, f.len);
            total += f.len;
            prev = f.t_ns;
        }
        Py_XDECREF(dlc_o);
        Py_XDECREF(fd_flags);
        fields_release(&f);
        if (plain < 0 || PyErr_Occurred())
            goto done;
        if (!ok) {
            Py_INCREF(Py_None);
            result = Py_None;
            goto done;
        }
    }
    {
        /* CDR_LE header, gap_ns (count, n uint32), id (count, n uint32), then flags, dlc, length,
         * data each as (count, bytes), every count aligned to 4 from the body's start (offset 4) */
        size_t size = 4 + 4 + 4 * n + 4 + 4 * n;
        size_t at_flags = size + 4;
        size_t size2 = at_flags + n;
        size_t pad1 = (4 - (size2 - 4) % 4) % 4, at_dlc = size2 + pad1 + 4;
        size_t size3 = at_dlc + n;
        size_t pad2 = (4 - (size3 - 4) % 4) % 4, at_len = size3 + pad2 + 4;
        size_t size4 = at_len + n;
        size_t pad3 = (4 - (size4 - 4) % 4) % 4, at_data = size4 + pad3 + 4;
        result = PyBytes_FromStringAndSize(NULL, at_data + total);
        if (!result)
            goto done;
        unsigned char *p = (unsigned char *)PyBytes_AS_STRING(result);
        memset(p, 0, at_data + total);
        p[0] = 0; p[1] = 1; p[2] = 0; p[3] = 0;  /* CDR_LE */
#define PUT32(at, v) do { uint32_t _v = (uint32_t)(v); p[(at)] = _v & 0xFF; p[(at) + 1] = (_v >> 8) & 0xFF; \
                          p[(at) + 2] = (_v >> 16) & 0xFF; p[(at) + 3] = (_v >> 24) & 0xFF; } while (0)
        PUT32(4, n);
        for (Py_ssize_t i = 0; i < n; i++)
            PUT32(8 + 4 * i, gaps[i]);
        PUT32(8 + 4 * n, n);
        for (Py_ssize_t i = 0; i < n; i++)
            PUT32(12 + 4 * n + 4 * i, ids[i]);
        PUT32(at_flags - 4, n);
        memcpy(p + at_flags, flags, n);
        PUT32(at_dlc - 4, n);
        memcpy(p + at_dlc, dlcs, n);
        PUT32(at_len - 4, n);
        memcpy(p + at_len, lens, n);
        PUT32(at_data - 4, total);
        memcpy(p + at_data, data, total);
#undef PUT32
    }
done:
    PyMem_Free(cols);
    Py_DECREF(seq);
    return result;
}

/* float_records.FloatLayout.pack: CDR_LE, then each field's value (a missing field NaN) as a
 * little-endian float64, converted as struct's "d" converts it; None when a value is not a float or
 * an int (None, a str, ...): the Python packer then packs or raises its error. */
static PyObject *pack_floats(PyObject *self, PyObject *args) {
    PyObject *fields, *values, *extra = NULL;
    if (!PyArg_ParseTuple(args, "O!O!|O", &PyTuple_Type, &fields, &PyDict_Type, &values, &extra))
        return NULL;
    Py_ssize_t n = PyTuple_GET_SIZE(fields), found = 0;
    if (extra) {  /* strict: None unless every key of ``values`` is a field or ``extra`` */
        int has = PyDict_Contains(values, extra);
        if (has < 0)
            return NULL;
        found = has;
    }
    PyObject *out = PyBytes_FromStringAndSize(NULL, 4 + 8 * n);
    if (!out)
        return NULL;
    unsigned char *p = (unsigned char *)PyBytes_AS_STRING(out);
    p[0] = 0; p[1] = 1; p[2] = 0; p[3] = 0;  /* CDR_LE */
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *v = PyDict_GetItemWithError(values, PyTuple_GET_ITEM(fields, i));
        double x;
        if (v == NULL) {
            if (PyErr_Occurred()) {
                Py_DECREF(out);
                return NULL;
            }
            x = Py_NAN;
        } else if (found++, PyFloat_Check(v)) {
            x = PyFloat_AS_DOUBLE(v);
        } else if (PyLong_CheckExact(v) || PyBool_Check(v)) {  /* what struct converts through int.__float__ */
            x = PyLong_AsDouble(v);
            if (x == -1.0 && PyErr_Occurred()) {
                PyErr_Clear();
                Py_DECREF(out);
                Py_RETURN_NONE;
            }
        } else {
            Py_DECREF(out);
            Py_RETURN_NONE;
        }
        if (PyFloat_Pack8(x, (char *)p + 4 + 8 * i, 1) < 0) {
            Py_DECREF(out);
            return NULL;
        }
    }
    if (extra && found != PyDict_GET_SIZE(values)) {  /* a key that is no field */
        Py_DECREF(out);
        Py_RETURN_NONE;
    }
    return out;
}

static PyMethodDef module_methods[] = {
    {"pack_floats", pack_floats, METH_VARARGS,
     "pack_floats(fields, values[, extra]): float_records.FloatLayout.pack's bytes, or None to leave it to "
     "Python; with ``extra`` also None when a key of ``values`` is neither a field nor ``extra``."},
    {"frame_bits", py_frame_bits, METH_VARARGS, "frame_bits(id, extended, data): busload.frame_bits of a data frame."},
    {"candump_lines", candump_lines, METH_VARARGS,
     "candump_lines(frames, epoch_ns, checked_channels, start): (text, next index)."},
    {"pack_plain", pack_plain, METH_O, "pack_plain(frames): can_batch.pack's bytes, or None when not plain."},
    {NULL},
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_framecore",
                                    "The rig's per-frame record path, compiled (see hil/fast/__init__.py).", -1,
                                    module_methods};

#define INTERN(var, text) if (!(var = PyUnicode_InternFromString(text))) return NULL

PyMODINIT_FUNC PyInit__framecore(void) {
    init_crc_table();
    INTERN(s_now_ns, "now_ns"); INTERN(s_t_ns, "t_ns"); INTERN(s_arbitration_id, "arbitration_id");
    INTERN(s_is_extended_id, "is_extended_id"); INTERN(s_is_error_frame, "is_error_frame");
    INTERN(s_is_remote_frame, "is_remote_frame"); INTERN(s_is_fd, "is_fd"); INTERN(s_data, "data");
    INTERN(s_dlc, "dlc"); INTERN(s_empty, ""); INTERN(s_channel, "channel"); INTERN(s_is_extended, "is_extended");
    INTERN(s_is_error, "is_error"); INTERN(s_is_remote, "is_remote"); INTERN(s_fd_flags, "fd_flags");
    if (PyType_Ready(&ItemType) < 0 || PyType_Ready(&CoreType) < 0)
        return NULL;
    PyObject *m = PyModule_Create(&module);
    if (!m)
        return NULL;
    Py_INCREF(&CoreType);
    Py_INCREF(&ItemType);
    if (PyModule_AddObject(m, "RecordCore", (PyObject *)&CoreType) < 0
        || PyModule_AddObject(m, "Queued", (PyObject *)&ItemType) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
