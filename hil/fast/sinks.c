/* The sinks' per-frame work of the compiled record path: candump lines (hil/record/candump.py),
 * /can/ records (hil/record/can_batch.py), float64 records (hil/record/float_records.py). */
#include "framecore.h"

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
PyObject *candump_lines(PyObject *self, PyObject *args) {
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
PyObject *pack_plain(PyObject *self, PyObject *frames) {
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
PyObject *pack_floats(PyObject *self, PyObject *args) {
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

