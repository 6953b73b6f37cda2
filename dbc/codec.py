"""DBC messages compiled once into shift-and-mask codecs for the rig's hot paths.

cantools' ``Message.encode``/``decode`` check and convert on every call
(3-12 us a frame); the emulators answer ~20 frames per 2 ms tick at many
times real time and the trace decodes every frame, so both use this codec. It
reads each signal's layout (start bit, length, byte order, sign, IEEE float,
scale, offset, range) from the cantools message once; the layout itself stays
described only in the DBC files. tests/test_dbc.py checks it against
cantools' encode and decode for every message of every DBC.

A payload is read as one integer: little-endian (Intel) signals from the
payload as a little-endian integer shifted by their start bit; big-endian
(Motorola) ones from the payload as a big-endian integer, their DBC start bit
being the MSB in sawtooth numbering. Raw values are the integers on the wire
(IEEE float signals: the float). Physical values are ``raw * scale + offset``
with cantools' types (an int where the conversion is the identity).

Two float-to-raw encoders: ``SignalCodec.rounded`` (nearest step, saturated
to the field: IMU, C620) and ``SignalCodec.truncated``, the CyberGear
manual's truncating ``float_to_uint`` (``truncate``; ``dbc.truncating_raw``
is the same function taking a cantools signal).
"""
from __future__ import annotations

import functools
import struct
from collections.abc import Mapping, Sequence

from cantools.database.conversion import BaseConversion, IdentityConversion

_FLOAT_FORMATS = {32: "f", 64: "d"}


def truncate(lo: float, hi: float, full: int, value: float) -> int:
    """``int((clamp(x, lo, hi) - lo) * full / (hi - lo))`` capped at ``full``; NaN -> 0.

    The manual's ``float_to_uint`` for an unsigned field of ``full = 2^bits - 1``
    over [lo, hi]: it truncates where cantools would round.
    """
    if value != value:  # NaN: every comparison of the clamp is false
        return 0
    value = lo if value < lo else hi if value > hi else value
    raw = int((value - lo) * full / (hi - lo))
    return full if full < raw else raw  # min(raw, full) without the builtin's call (four a control tick)


class SignalCodec:
    """One signal's place in the payload integer and its raw <-> physical conversions."""

    __slots__ = ("name", "big", "shift", "mask", "sign", "float_format", "scale", "offset",
                 "minimum", "maximum", "raw_lo", "raw_hi", "conv_scale", "conv_offset", "truncated")

    def __init__(self, signal, length: int):
        bits = signal.length
        self.name = signal.name
        if signal.byte_order == "little_endian":
            self.big, self.shift = False, signal.start
        else:
            msb = 8 * (signal.start // 8) + 7 - signal.start % 8  # network bit number of the MSB
            self.big, self.shift = True, 8 * length - msb - bits
        if self.shift < 0 or self.shift + bits > 8 * length:
            raise ValueError(f"signal {signal.name} does not fit a {length}-byte payload")
        self.mask = (1 << bits) - 1
        self.sign = 1 << (bits - 1) if signal.is_signed and not signal.is_float else 0
        self.float_format = _FLOAT_FORMATS[bits] if signal.is_float else None
        self.scale, self.offset = signal.scale, signal.offset
        self.minimum, self.maximum = signal.minimum, signal.maximum
        self.raw_lo, self.raw_hi = (-self.sign, self.sign - 1) if self.sign else (0, self.mask)
        # the numeric conversion cantools applies when choices are not decoded
        conv = BaseConversion.factory(scale=signal.scale, offset=signal.offset, choices=None,
                                      is_float=signal.is_float)
        identity = isinstance(conv, IdentityConversion)
        self.conv_scale, self.conv_offset = (None, None) if identity else (conv.scale, conv.offset)
        # the manual's truncating encoder over [minimum, maximum] (``truncate``), unsigned fields
        self.truncated = functools.partial(truncate, self.minimum, self.maximum, self.mask) \
            if self.has_span() else functools.partial(_no_span, self.name, self.minimum, self.maximum)

    def has_span(self) -> bool:
        """Whether the DBC gives a range of more than one value, which truncation maps onto the field."""
        return self.minimum is not None and self.maximum is not None and self.minimum < self.maximum

    # -- raw <-> physical ----------------------------------------------------------
    def value(self, raw):
        """Physical value of a raw value, typed as cantools' ``decode`` types it."""
        if self.conv_scale is None:
            return raw
        return raw * self.conv_scale + self.conv_offset

    def rounded(self, value: float) -> int:
        """Nearest raw step of ``value``, saturated to the field; NaN encodes as the raw value of 0."""
        if value != value:
            value = 0.0
        raw = (value - self.offset) / self.scale
        if raw >= self.raw_hi:
            return self.raw_hi
        if raw <= self.raw_lo:
            return self.raw_lo
        return int(round(raw))


class MessageCodec:
    """Raw and physical encode/decode of one DBC message, or of a subset of its signals.

    For a multiplexed message pass the multiplexer plus the signals of one
    multiplexer value; the whole multiplexed message picks its branch by the
    multiplexer's value (``branches``). ``encode_raw`` needs every chosen
    signal and raises ValueError for a raw value outside its field;
    ``decode_raw``/``decode`` need exactly ``length`` bytes (else ValueError).

    The three functions are generated Python (one expression per signal,
    constants bound by name), compiled once per codec: ~1 us a frame.
    """

    def __init__(self, message, signals: Sequence | None = None):
        if message.is_container:
            raise ValueError(f"{message.name}: container messages are not compiled")
        self.message = message
        self.name = message.name
        self.frame_id = message.frame_id
        self.length = message.length
        chosen = list(message.signals if signals is None else signals)
        self.fields = tuple(SignalCodec(s, self.length) for s in chosen)
        self.signals = {f.name: f for f in self.fields}
        self.multiplexer: SignalCodec | None = None
        self.branches: dict[int, MessageCodec] = {}  # multiplexer value -> codec of that branch
        if signals is None and message.is_multiplexed():
            self._compile_branches(message)
            self.encode_raw, self.decode_raw, self.decode = self._by_branch()
        else:
            self.encode_raw, self.decode_raw, self.decode = _compiled(self)

    def encoder(self, kinds: Mapping[str, str]):
        """A compiled ``encode(*values) -> bytes``: one value per signal, in the order of ``kinds``.

        ``kinds`` maps every signal of the codec to how its value becomes the raw
        field: ``"raw"`` as it is, ``"rounded"`` (``SignalCodec.rounded``) or
        ``"truncated"`` (``SignalCodec.truncated``). The bytes and the errors are
        ``encode_raw``'s of those raw values, without a dict or a call per field
        (the emulators' feedback frames, thousands a simulated second).
        """
        return _compiled_encoder(self, dict(kinds))

    @staticmethod
    @functools.lru_cache(maxsize=None)
    def of(message) -> "MessageCodec":
        """The codec of a whole cantools message, compiled once per message object."""
        return MessageCodec(message)

    def _compile_branches(self, message) -> None:
        muxes = [s for s in message.signals if s.is_multiplexer]
        if len(muxes) != 1 or any(s.multiplexer_signal not in (None, muxes[0].name) for s in message.signals):
            raise ValueError(f"{message.name}: only one level of multiplexing is supported")
        mux = muxes[0]
        values = sorted({i for s in message.signals for i in (s.multiplexer_ids or ())})
        self.multiplexer = self.signals[mux.name]
        # each branch keeps the message's signal order (cantools': by start bit), as its decode does
        self.branches = {i: MessageCodec(message, [s for s in message.signals
                                                   if s.multiplexer_ids is None or i in s.multiplexer_ids])
                         for i in values}

    def _by_branch(self):
        """encode_raw, decode_raw, decode of a whole multiplexed message."""
        read_mux = MessageCodec(self.message, [self.message.get_signal_by_name(self.multiplexer.name)]).decode_raw
        name = self.multiplexer.name

        def branch(data: bytes) -> MessageCodec:
            value = read_mux(data)[name]
            codec = self.branches.get(value)
            if codec is None:
                raise ValueError(f"{self.name}: no signals for multiplexer {name} = {value}")
            return codec

        def encode_raw(raw: Mapping) -> bytes:
            codec = self.branches.get(raw[name])
            if codec is None:
                raise ValueError(f"{self.name}: no signals for multiplexer {name} = {raw[name]!r}")
            return codec.encode_raw(raw)

        return encode_raw, (lambda data: branch(data).decode_raw(data)), (lambda data: branch(data).decode(data))


def _compiled(codec: MessageCodec):
    """Generate and compile encode_raw, decode_raw and decode of a codec without branches."""
    n, fields = codec.length, codec.fields
    env = {"_length_error": _length_error, "_range_error": _range_error, "_fields": fields}
    reads, values, orders = [], [], set()
    for i, f in enumerate(fields):
        word = "b" if f.big else "l"
        orders.add(word)
        read = f"v{i} = ({word} >> {f.shift}) & {f.mask}"
        if f.float_format is not None:
            env[f"unpack{i}"] = struct.Struct("<" + f.float_format).unpack
            read += f"; v{i} = unpack{i}(v{i}.to_bytes({f.mask.bit_length() // 8}, 'little'))[0]"
        elif f.sign:
            read += f"\n    if v{i} & {f.sign}: v{i} -= {f.sign << 1}"
        reads.append(read)
        if f.conv_scale is None:
            values.append(f"{f.name!r}: v{i}")
        else:
            env[f"s{i}"], env[f"o{i}"] = f.conv_scale, f.conv_offset
            values.append(f"{f.name!r}: v{i} * s{i} + o{i}")
    names = "".join(f"v{i}, " for i in range(len(fields)))
    words = [f"{w} = int.from_bytes(data, {order!r})" for w, order in (("b", "big"), ("l", "little")) if w in orders]
    head = f"    if len(data) != {n}: _length_error({codec.name!r}, data, {n})\n" + "".join(
        f"    {line}\n" for line in words + reads)
    source = (f"def decode_raw(data):\n{head}    return {{{', '.join(f'{f.name!r}: v{i}' for i, f in enumerate(fields))}}}\n"
              f"def decode(data):\n{head}    return {{{', '.join(values)}}}\n"
              f"def encode_raw(raw):\n"
              + (f"    {names}= {''.join(f'raw[{f.name!r}], ' for f in fields)}\n" if fields else "")
              + _packing(codec, env))
    exec(compile(source, f"<codec {codec.name}>", "exec"), env)  # noqa: S102 - source built above from the DBC
    return env["encode_raw"], env["decode_raw"], env["decode"]


def _packing(codec: MessageCodec, env: dict) -> str:
    """Source lines that check the raw values v0, v1, ... (one per field) and return the payload."""
    n, fields = codec.length, codec.fields
    parts, checks = {"b": [], "l": []}, []
    for i, f in enumerate(fields):
        word = "b" if f.big else "l"
        if f.float_format is not None:
            env[f"pack{i}"] = struct.Struct("<" + f.float_format).pack
            parts[word].append(f"int.from_bytes(pack{i}(v{i}), 'little') << {f.shift}")
        else:
            checks.append(f"{f.raw_lo} <= v{i} <= {f.raw_hi}")
            parts[word].append(f"(v{i} & {f.mask}) << {f.shift}" if f.sign else f"v{i} << {f.shift}")
    names = "".join(f"v{i}, " for i in range(len(fields)))
    big, little = " | ".join(parts["b"]) or "0", " | ".join(parts["l"]) or "0"
    if not fields:
        payload = f"bytes({n})"
    elif not parts["l"]:
        payload = f"({big}).to_bytes({n}, 'big')"
    elif not parts["b"]:
        payload = f"({little}).to_bytes({n}, 'little')"
    else:
        payload = f"({little} | int.from_bytes(({big}).to_bytes({n}, 'big'), 'little')).to_bytes({n}, 'little')"
    return ((f"    if not ({' and '.join(checks)}): _range_error(_fields, ({names}))\n" if checks else "")
            + f"    return {payload}\n")


def _compiled_encoder(codec: MessageCodec, kinds: dict):
    """Generate and compile ``MessageCodec.encoder``'s function (see there)."""
    if codec.branches:
        raise ValueError(f"{codec.name}: a multiplexed message is encoded by one branch's codec")
    if sorted(kinds) != sorted(codec.signals) or set(kinds.values()) - {"raw", "rounded", "truncated"}:
        raise ValueError(f"{codec.name}: need each of {sorted(codec.signals)} once as raw, rounded or "
                         f"truncated, got {kinds}")
    env = {"_range_error": _range_error, "_fields": codec.fields}
    index = {f.name: i for i, f in enumerate(codec.fields)}
    lines = []
    for name, how in kinds.items():
        i, f = index[name], codec.signals[name]
        if how != "raw" and f.float_format is not None:
            raise ValueError(f"{codec.name}: {name} is an IEEE float, its value goes in raw")
        if how == "raw":
            lines.append(f"v{i} = a{i}")
        elif how == "rounded":  # SignalCodec.rounded
            env[f"off{i}"], env[f"sc{i}"] = f.offset, f.scale
            lines += [f"if a{i} != a{i}: a{i} = 0.0", f"r{i} = (a{i} - off{i}) / sc{i}",
                      f"v{i} = {f.raw_hi} if r{i} >= {f.raw_hi} else {f.raw_lo} if r{i} <= {f.raw_lo} "
                      f"else int(round(r{i}))"]
        else:  # truncate(minimum, maximum, mask, value)
            if not f.has_span():
                _no_span(f"{codec.name}.{name}", f.minimum, f.maximum)
            env[f"lo{i}"], env[f"hi{i}"], env[f"span{i}"] = f.minimum, f.maximum, f.maximum - f.minimum
            lines += [f"if a{i} != a{i}: v{i} = 0", "else:",
                      f"    a{i} = lo{i} if a{i} < lo{i} else hi{i} if a{i} > hi{i} else a{i}",
                      f"    v{i} = int((a{i} - lo{i}) * {f.mask} / span{i})",
                      f"    if v{i} > {f.mask}: v{i} = {f.mask}"]
    args = ", ".join(f"a{index[name]}" for name in kinds)
    source = f"def encode({args}):\n" + "".join(f"    {line}\n" for line in lines) + _packing(codec, env)
    exec(compile(source, f"<encoder {codec.name}>", "exec"), env)  # noqa: S102 - source built above from the DBC
    return env["encode"]


def _length_error(name: str, data: bytes, length: int):
    raise ValueError(f"{name}: {len(data)} bytes, expected {length}")


def _no_span(name: str, minimum, maximum, *_):
    raise ValueError(f"{name}: its DBC range [{minimum}|{maximum}] has no span to truncate a value over "
                     f"(the manual's float_to_uint needs minimum < maximum); encode it raw or rounded")


def _range_error(fields: tuple, raws: tuple):
    for field, raw in zip(fields, raws):
        if field.float_format is None and not field.raw_lo <= raw <= field.raw_hi:
            raise ValueError(f"{field.name}: raw value {raw!r} outside {field.raw_lo}..{field.raw_hi}")
