/* DBC signal codec on one 8-byte payload: the payload as one integer (little-endian bytes
   for Intel signals, big-endian for Motorola ones, as wheelleg.dbc.codec reads it). */
#include "dbc_codec.h"

#include <math.h>

static uint64_t payload_int(const uint8_t *data, uint8_t length, bool big) {
    uint64_t word = 0;
    for (uint8_t i = 0; i < length; i++) {
        uint8_t byte = big ? data[i] : data[length - 1u - i];
        word = (word << 8) | byte;
    }
    return word;
}

static void put_payload_int(uint8_t *data, uint8_t length, bool big, uint64_t word) {
    for (uint8_t i = 0; i < length; i++) {
        uint8_t byte = (uint8_t)(word >> (8u * i));
        if (big) {
            data[length - 1u - i] = byte;
        } else {
            data[i] = byte;
        }
    }
}

static uint64_t field_mask(uint8_t bits) {
    return bits >= 64 ? ~(uint64_t)0 : (((uint64_t)1 << bits) - 1u);
}

int64_t wl_sig_raw(const uint8_t *data, uint8_t length, const wl_signal_t *sig) {
    uint64_t raw = (payload_int(data, length, sig->big != 0) >> sig->shift) & field_mask(sig->bits);
    if (sig->is_signed && sig->bits < 64 && (raw >> (sig->bits - 1u)) & 1u) {
        return (int64_t)raw - (int64_t)((uint64_t)1 << sig->bits);
    }
    return (int64_t)raw;
}

bool wl_sig_get(const uint8_t *data, uint8_t length, const wl_signal_t *sig, float *value) {
    double v = (double)wl_sig_raw(data, length, sig) * sig->scale + sig->offset;
    *value = (float)v;
    return v >= sig->minimum - 1e-9 && v <= sig->maximum + 1e-9;  /* the DBC's range with 1e-9 of slack */
}

void wl_sig_put_raw(uint8_t *data, uint8_t length, const wl_signal_t *sig, int64_t raw) {
    bool big = sig->big != 0;
    uint64_t word = payload_int(data, length, big);
    uint64_t mask = field_mask(sig->bits) << sig->shift;
    word = (word & ~mask) | (((uint64_t)raw << sig->shift) & mask);
    put_payload_int(data, length, big, word);
}

int64_t wl_sig_rounded(const wl_signal_t *sig, float value) {
    int64_t lo = sig->is_signed ? -((int64_t)1 << (sig->bits - 1u)) : 0;
    int64_t hi = sig->is_signed ? ((int64_t)1 << (sig->bits - 1u)) - 1 : (int64_t)field_mask(sig->bits);
    if (value != value) value = 0.0f;
    double raw = ((double)value - sig->offset) / sig->scale;
    if (raw >= (double)hi) return hi;
    if (raw <= (double)lo) return lo;
    return (int64_t)nearbyint(raw);  /* half to even, as Python's round */
}

uint32_t wl_sig_truncated(const wl_signal_t *sig, float value) {
    uint32_t full = (uint32_t)field_mask(sig->bits);
    if (value != value) return 0;
    double lo = sig->minimum, hi = sig->maximum;
    double v = (double)value;
    v = v < lo ? lo : v > hi ? hi : v;
    double raw = (v - lo) * (double)full / (hi - lo);
    uint32_t r = (uint32_t)raw;
    return r > full ? full : r;
}
