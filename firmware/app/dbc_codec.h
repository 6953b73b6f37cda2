/* A DBC signal's place in a payload and its scaling, and the codec functions on it.
   The layouts themselves are generated from dbc/ into wl_config.h (WL_SIG_*). */
#ifndef WL_DBC_CODEC_H
#define WL_DBC_CODEC_H

#include <stdbool.h>
#include <stdint.h>

typedef struct {
    uint8_t big;        /* 1: big-endian (Motorola) signal */
    uint8_t shift;      /* bit position of its LSB in the payload integer (little- or big-endian bytes) */
    uint8_t bits;
    uint8_t is_signed;
    double scale, offset, minimum, maximum;  /* double: the DBC's own numbers, checked as the Python codec does */
} wl_signal_t;

/* The raw field of sig in data[0..length) (sign-extended when signed). */
int64_t wl_sig_raw(const uint8_t *data, uint8_t length, const wl_signal_t *sig);
/* The physical value raw * scale + offset; false when it lies outside [minimum, maximum]
   (the checks every decoded frame gets; the value is still written). */
bool wl_sig_get(const uint8_t *data, uint8_t length, const wl_signal_t *sig, float *value);
/* Write the raw field of sig into data[0..length) (the field's bits only). */
void wl_sig_put_raw(uint8_t *data, uint8_t length, const wl_signal_t *sig, int64_t raw);
/* The raw value nearest value, saturated to the field; NaN encodes as the raw of 0. */
int64_t wl_sig_rounded(const wl_signal_t *sig, float value);
/* The manual's truncating encoder (float_to_uint) over [minimum, maximum] of an unsigned field. */
uint32_t wl_sig_truncated(const wl_signal_t *sig, float value);

#endif
