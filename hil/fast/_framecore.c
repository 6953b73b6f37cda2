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
 *
 * The files: wire.c (frame bits, the wire model), frames.c (a Frame from a can.Message),
 * record_core.c (the recorder's core), sinks.c (candump lines, /can/ and float64 records);
 * framecore.h their shared declarations.
 */
#include "framecore.h"

PyObject *s_now_ns, *s_t_ns, *s_arbitration_id, *s_is_extended_id, *s_is_error_frame, *s_is_remote_frame, *s_is_fd,
    *s_data, *s_dlc, *s_empty, *s_channel, *s_is_extended, *s_is_error, *s_is_remote, *s_fd_flags;

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
    /* what hil/fast/__init__.py expects (VERSION there): a build of other sources is not used */
    if (PyModule_AddIntConstant(m, "VERSION", 1) < 0 || PyModule_AddObject(m, "RecordCore", (PyObject *)&CoreType) < 0
        || PyModule_AddObject(m, "Queued", (PyObject *)&ItemType) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
