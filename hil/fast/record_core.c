/* The recorder's core (hil/bus/recorder.py Recorder): noting frames, settling them on their wires,
 * handing them over in time order. */
#include "framecore.h"


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

PyTypeObject CoreType = {
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

