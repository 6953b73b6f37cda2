/* Frames of the compiled record path: a Frame record and its wire entry from a python-can Message
 * (hil/bus/recorder.py _frame), the Frame made slot by slot. */
#include "framecore.h"


/* The Frame class's slot offsets (``__slots__`` member descriptors, in the dataclass's field order) and
 * the defaults an instance made with the 10 leading fields gets; left 0 when the class is not laid out
 * so (then frames are made by calling it). */
int core_find_slots(Core *c) {
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


static int attr_true(PyObject *obj, PyObject *name, PyObject **out) {
    *out = PyObject_GetAttr(obj, name);
    if (!*out)
        return -1;
    return PyObject_IsTrue(*out);
}

/* The Frame of ``msg`` on channel ``ch`` (recorder._frame) and its wire-model entry. */
Item *core_item(Core *c, int ch, PyObject *msg) {
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

