"""Decoded signals derived on reading: a trace's raw frames and its own DBC attachments.

A run's trace keeps the raw frames (``/can/<channel>``); the DBC signals of
every frame are derived when a reader asks for them (``TraceReader.decoded``,
``TraceReader.topic("/decoded/...")``), one numpy pass per message over all its
frames (``DecodePlan.decode_columns``). The values are those a
``/decoded/<channel>/<Message>`` JSON topic recorded live gives back: the same
numbers, NaN where a frame lacks a field, and NaN for a value that is not
finite (JSON writes it as null). ``wheelleg export`` writes those topics into a
copy of the trace for Foxglove.

The databases come from the trace itself: each bus's DBC files (the
``Bus.dbc_files`` of the robot in the ``run`` record, wheelleg.hil.robots) are
read from the trace's attachments by file name, so a trace decodes with the
layouts it was recorded with; a file the trace lacks is read where the robot
keeps it.
"""
from __future__ import annotations

import functools
import math

import cantools
import numpy as np

from wheelleg import dbc
from wheelleg.hil import robots
from wheelleg.hil.record.decode import FrameDecoder
from wheelleg.hil.record.frame import FrameColumns


def attached_dbs(attachments: dict[str, bytes], run: dict[str, str]) -> dict[str, cantools.database.Database]:
    """Channel (interface name) -> the cantools database of its bus, from the trace's DBC attachments.

    ``run``: the trace's ``run`` record (its ``robot`` and the interface name of each role);
    {} when the record names no channel (a trace not written by a run).
    """
    try:
        files = robots.bus_files(run.get("robot") or robots.DEFAULT)
    except KeyError:  # a robot this rig cannot load: no layouts to decode with
        return {}
    out = {}
    for role, names in files.items():
        channel = run.get(role)
        if channel:
            texts = tuple(_dbc_text(attachments, dbc.resolve(file)) for file in names)
            out[channel] = _database(texts)
    return out


def _dbc_text(attachments: dict[str, bytes], path) -> str:
    data = attachments.get(path.name)
    return data.decode() if data is not None else path.read_text()


@functools.lru_cache(maxsize=16)
def _database(texts: tuple[str, ...]) -> cantools.database.Database:
    """One database of the DBC texts (cached: every trace of a run carries the same files)."""
    db = cantools.database.Database()
    for text in texts:
        db.add_dbc_string(text)
    return db


def decoded_columns(decoder: FrameDecoder, channel: str, frames: FrameColumns, message: str) -> dict[str, np.ndarray]:
    """'t' (s) and every field of ``message`` over ``frames`` (``channel``'s), shape (n,); {} if none.

    Keys in the order a JSON topic gives them: 't', then each field as it first
    appears; a frame without a field (another multiplexer value, a request
    among replies) has NaN there. The plan of each distinct id is looked up once.
    """
    keys = frames.arbitration_id * 2 + frames.is_extended  # (id, extended) as one number
    distinct = np.unique(keys[~frames.is_error])
    plans = {int(k): decoder.plan(channel, int(k) >> 1, bool(k & 1)) for k in distinct}
    mine = [k for k, p in plans.items() if p is not None and p.name == message]
    if not mine:
        return {}
    plan = plans[mine[-1]]  # one plan per channel and message
    where = np.flatnonzero(np.isin(keys, mine) & ~frames.is_error)
    times, ids = frames.t_ns[where], frames.arbitration_id[where].tolist()
    payloads = [frames.data[i] for i in where.tolist()]
    batch = plan.decode_columns(ids, payloads)
    if batch is not None:
        names, columns, id_fields = batch
        out = {"t": times / 1e9}
        for name, column in zip(names, columns):
            out[name] = _finite(np.array(column, dtype=float))
        if id_fields is not None:
            out.update(_field_columns(id_fields))
        return out
    rows = [(t, plan.decode(i, d)) for t, i, d in zip(times.tolist(), ids, payloads)]
    return decoded_rows_columns([(t, row) for t, row in rows if row is not None])


def decoded_rows_columns(rows: list[tuple[int, dict]]) -> dict[str, np.ndarray]:
    """(t_ns, values) rows -> 't' (s) and one float array per field (missing -> NaN, not finite -> NaN)."""
    out = rows_columns(rows, time_key="t")
    for key, column in out.items():
        if key != "t":
            _finite(column)
    return out


def rows_columns(rows: list[tuple[int, dict]], time_key: str | None = None) -> dict[str, np.ndarray]:
    """Rows of dicts (t_ns, {key: value}) -> one float array per key, shape (n,), in the order the keys
    first appear (``time_key``, if given, first: the rows' times in s); missing, null, text -> NaN."""
    if not rows:
        return {}
    keys: dict[str, None] = {}
    if time_key:
        keys[time_key] = None
    for _, row in rows:
        keys.update(dict.fromkeys(row))
    out = {}
    for key in keys:
        if key == time_key:
            out[key] = np.array([t for t, _ in rows], dtype=np.int64) / 1e9
        else:
            out[key] = _floats([row.get(key) for _, row in rows])
    return out


def _field_columns(id_fields: list[dict]) -> dict[str, np.ndarray]:
    """The CyberGear id fields, one dict per frame (shared between frames of one id), by column."""
    keys = dict.fromkeys(k for fields in {id(f): f for f in id_fields}.values() for k in fields)
    return {key: _finite(_floats([fields.get(key) for fields in id_fields])) for key in keys}


def _floats(values: list) -> np.ndarray:
    """Numbers -> float array; None (missing, null) and strings -> NaN."""
    try:
        out = np.array(values, dtype=float)  # None -> NaN
        if out.ndim == 1:
            return out
    except (TypeError, ValueError):  # a string among them
        pass
    return np.array([_float(v) for v in values], dtype=float)


def _float(value) -> float:
    return math.nan if value is None or isinstance(value, str) else float(value)


def _finite(values: np.ndarray) -> np.ndarray:
    """NaN where a value is not finite: what a JSON topic (null) reads back as."""
    bad = ~np.isfinite(values)
    if bad.any():
        values[bad] = math.nan
    return values
