/* The wire model of the compiled record path: frame bits, arbitration heaps, one bus's wire
 * (hil/bus/busload.py frame_bits, hil/bus/wire_order.py BusWire). */
#include "framecore.h"

/* ------------------------------------------------------------------------------------------ */
/* CAN frame bits (busload.frame_bits): header, payload, CRC-15, stuff bits, trailer            */

static uint16_t crc_table[256];

void init_crc_table(void) {
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
int64_t frame_bits(uint32_t id, int extended, const unsigned char *data, Py_ssize_t len) {
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

PyObject *py_frame_bits(PyObject *self, PyObject *args) {
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

PyTypeObject ItemType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "wheelleg.hil.fast._framecore.Queued",
    .tp_basicsize = sizeof(Item),
    .tp_dealloc = (destructor)item_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "One frame on a wire of the compiled record path (the handle of a received frame).",
    .tp_getset = item_getset,
};


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
int heap_push(Heap *h, Item *it, int (*less)(const Item *, const Item *)) {
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

int fifo_push(Fifo *q, Item *it) {
    if (q->head > 0 && q->head + q->n == q->cap) {  /* slide to the front */
        memmove(q->v, q->v + q->head, q->n * sizeof(Item *));
        q->head = 0;
    }
    if (grow(&q->v, &q->cap, q->head + q->n + 1) < 0)
        return -1;
    q->v[q->head + q->n++] = it;
    return 0;
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


void wire_clear(Wire *w) {
    fifo_clear(&w->controller);
    heap_clear(&w->timed);
    heap_clear(&w->eligible);
    fifo_clear(&w->sent);
    Py_CLEAR(w->last);
}


/* wire_order.BusWire._queued: counts, key, ready time; the wire's last frame */
void wire_queued(Wire *w, Item *it, int64_t ready_ns, int has_ready, int is_error, int64_t prio) {
    w->busy_ns_total += it->wire_ns;
    w->frames_total += 1;
    it->seq = ++w->seq;
    it->prio = is_error ? -1 : prio;
    it->ready_ns = ready_ns;
    it->has_ready = has_ready;
    Py_INCREF(it);
    Py_XSETREF(w->last, it);
}

int wire_send(Core *c, Wire *w, Item *it, int64_t start_ns) {
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
int wire_run_until(Core *c, Wire *w, int64_t now_ns, int until_none) {
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
int wire_queue(Core *c, Wire *w, Item *it, int64_t ready_ns, Item *answers, int is_error, int64_t prio) {
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

int64_t frame_prio(int64_t id, int extended, int remote) {
    if (extended)
        return ((id >> 18) << 21) | (1 << 20) | ((id & 0x3FFFF) << 1) | remote;
    return (id << 21) | remote;
}

