"""JSON for the trace's JSON channels: orjson when installed (NaN -> null), else the json module.

``json_rows`` writes the ``/decoded/`` rows of a batch by column (``TraceWriter``
with ``decode=True``); the bytes are those ``dumps`` gives each row's dict.
"""
from __future__ import annotations

import json
import math

import numpy as np

try:  # optional: 10x faster float formatting than the json module
    import orjson
except ImportError:
    orjson = None



def _plain(value):
    """numpy scalars/arrays -> Python; used by both encoders as their fallback."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON serializable")


def _finite(value):
    """The json module has no NaN -> null; orjson does it by itself."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


if orjson is not None:
    _ORJSON_OPTIONS = orjson.OPT_SERIALIZE_NUMPY

    def dumps(obj) -> bytes:
        """Compact JSON bytes; NaN and inf become null."""
        return orjson.dumps(obj, default=_plain, option=_ORJSON_OPTIONS)

    loads = orjson.loads
else:
    _ENCODER = json.JSONEncoder(separators=(",", ":"), allow_nan=False, default=_plain)

    def dumps(obj) -> bytes:
        """Compact JSON bytes; NaN and inf become null."""
        try:
            return _ENCODER.encode(obj).encode()
        except ValueError:
            return _ENCODER.encode(_finite(obj)).encode()

    loads = json.loads


def json_rows(names: list[str], columns: list[list], id_fields: list[dict] | None, n: int) -> list[bytes]:
    """``dumps`` of each row {name: value, ..., **id fields} without a dict or an encoder call per row.

    Each column is encoded once as a list of numbers and split at its commas
    (a number holds none); the id fields, shared by the frames of one id, are
    encoded once per id; a row is then one ``%`` into a template of its keys.
    The bytes are those ``dumps`` gives the row's dict (a test compares them).
    """
    template = b",".join(dumps(name).replace(b"%", b"%%") + b":%s" for name in names)
    texts = [dumps(column)[1:-1].split(b",") for column in columns]
    if id_fields is not None:
        encoded: dict[int, bytes] = {}  # id(fields dict) -> its members' text, after a comma if it needs one
        for fields in id_fields:
            if id(fields) not in encoded:
                members = dumps(fields)[1:-1]
                encoded[id(fields)] = b"," + members if members and names else members
        template += b"%s"
        texts.append([encoded[id(fields)] for fields in id_fields])
    if not texts:
        return [b"{}"] * n
    template = b"{" + template + b"}"
    return [template % values for values in zip(*texts)]
