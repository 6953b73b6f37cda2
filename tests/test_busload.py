"""Bus-load model: frame lengths with exact bit stuffing, arbitration rank."""
import random

import numpy as np

from wheelleg.hil.bus.busload import (BATCH_MIN, arbitration_priority, frame_bits, max_frame_bits, wire_ns,
                                      wire_ns_batch)
from wheelleg.hil.record.frame import Frame


def _reference_bits(arbitration_id, extended, data):
    """Bit-by-bit construction of a classic frame, the way the CAN spec draws it."""
    def bits(v, w):
        return [(v >> (w - 1 - i)) & 1 for i in range(w)]
    if extended:
        head = [0] + bits(arbitration_id >> 18, 11) + [1, 1] + bits(arbitration_id & 0x3FFFF, 18) + [0, 0, 0]
    else:
        head = [0] + bits(arbitration_id, 11) + [0, 0, 0]
    body = head + bits(len(data), 4) + [b for byte in data for b in bits(byte, 8)]
    crc = 0
    for b in body:
        nxt = b ^ ((crc >> 14) & 1)
        crc = (crc << 1) & 0x7FFF
        if nxt:
            crc ^= 0x4599
    stuffed_part = body + bits(crc, 15)
    stuffs, run, last = 0, 0, None
    for b in stuffed_part:
        run, last = (run + 1, last) if b == last else (1, b)
        if run == 5:
            stuffs, last, run = stuffs + 1, 1 - b, 1
    return len(stuffed_part) + stuffs + 13


def test_frame_bits_match_the_bit_by_bit_reference():
    rng = random.Random(11)
    for _ in range(3000):
        ext = rng.random() < 0.5
        arb = rng.getrandbits(29 if ext else 11)
        data = bytes(rng.choice([0x00, 0xFF, 0xF0, rng.getrandbits(8)]) for _ in range(rng.randint(0, 8)))
        assert frame_bits(arb, ext, data) == _reference_bits(arb, ext, data)


def test_known_lengths():
    # an all-zero 8-byte standard frame: 111 bits before stuffing, plus its stuff bits
    assert frame_bits(0x000, False, bytes(8)) > 111 + 13
    assert frame_bits(0x080, False, bytes(4)) < frame_bits(0x080, False, bytes(8))
    assert frame_bits(0x01000001, True, bytes(8)) > frame_bits(0x001, False, bytes(8)) + 18


def test_arbitration_rank_is_the_bits_as_they_meet_on_the_wire():
    rank = arbitration_priority
    assert rank(0x080, False) < rank(0x0200_0100, True) < rank(0x081, False)  # base ids first (0x080 both)
    assert rank(0x080, False, is_remote=True) < rank(0x0200_0000, True)  # IDE: standard over extended
    assert rank(0x123, False) < rank(0x123, False, is_remote=True)  # RTR: data over remote
    assert rank(0x0200_0001, True) < rank(0x0200_0002, True) < rank(0x0200_0002, True, is_remote=True)
    assert rank(0x0100_FD01, True) < rank(0x0200_01FD, True) < rank(0x0400_FD02, True)  # CyberGear types 1 < 2 < 4


def test_wire_time_of_a_batch_is_each_frames_wire_time():
    rng = random.Random(12)
    frames = []
    for _ in range(500):
        ext = rng.random() < 0.5
        data = bytes(rng.choice([0x00, 0xFF, rng.getrandbits(8)]) for _ in range(rng.randint(0, 8)))
        frames.append(Frame(0, "vcan0", rng.getrandbits(29 if ext else 11), ext, data, len(data),
                            is_error=rng.random() < 0.05))
    for bitrate in (1_000_000, 500_000, 333_333):
        expected = [wire_ns(f.arbitration_id, f.is_extended, f.data, bitrate) for f in frames]
        assert wire_ns_batch(frames, bitrate) == expected  # numpy
        assert wire_ns_batch(frames[:BATCH_MIN - 1], bitrate) == expected[:BATCH_MIN - 1]  # one by one
    odd = [*frames[:BATCH_MIN], Frame(0, "vcan0", 0x900, False, b"\x01", 1)]  # a standard id past 11 bits
    assert wire_ns_batch(odd, 1_000_000)[-1] == wire_ns(0x900, False, b"\x01", 1_000_000)


def test_max_frame_bits_bounds_every_frame_of_its_format():
    rng = np.random.default_rng(7)
    for extended in (False, True):
        for length in range(9):
            bound = int(max_frame_bits([extended], [length])[0])
            for payload in (bytes(length), b"\xff" * length, bytes(rng.integers(0, 256, length, dtype=np.uint8))):
                for ident in (0, (1 << (29 if extended else 11)) - 1, int(rng.integers(0, 1 << 11))):
                    assert frame_bits(ident, extended, payload) <= bound
            assert bound - frame_bits(0, extended, bytes(length)) < 30  # a bound, not a guess far off
