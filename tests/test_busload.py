"""Bus-load model: frame lengths with exact bit stuffing, serialisation on one bus."""
import random


from wheelleg.hil.bus.busload import BusClock, frame_bits


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
        assert frame_bits.__wrapped__(arb, ext, data) == _reference_bits(arb, ext, data)


def test_known_lengths():
    # an all-zero 8-byte standard frame: 111 bits before stuffing, plus its stuff bits
    assert frame_bits(0x000, False, bytes(8)) > 111 + 13
    assert frame_bits(0x080, False, bytes(4)) < frame_bits(0x080, False, bytes(8))
    assert frame_bits(0x01000001, True, bytes(8)) > frame_bits(0x001, False, bytes(8)) + 18


def test_bus_clock_serialises_frames_and_totals_their_wire_time():
    clock = BusClock(bitrate=1_000_000)
    bits = frame_bits(0x200, False, bytes(8))
    ends = [clock.transmit(0, 0x200, False, bytes(8)) for _ in range(3)]
    assert ends == [bits * 1000, 2 * bits * 1000, 3 * bits * 1000]  # ns at 1 Mbit/s
    assert (clock.busy_ns_total, clock.frames_total) == (3 * bits * 1000, 3)  # back to back: load 1
    assert clock.transmit(2_000_000_000, 0x200, False, bytes(8)) == 2_000_000_000 + bits * 1000  # idle bus
    assert (clock.busy_ns_total, clock.frames_total) == (4 * bits * 1000, 4)
