/* Radio frames as bytes: see frames.h and firmware_model/frames.py (the layouts as data). */
#include "frames.h"

#define WRAP 0
#define SATURATE 1
#define REJECT 2

typedef struct {
    int32_t width;  /* bytes */
    int32_t is_signed;
    int32_t policy;
} nf_field;

static const nf_field ESTIMATE_FIELDS[] = {
    {2, 0, REJECT}, {2, 0, WRAP}, {4, 0, WRAP}, {4, 1, WRAP}, {4, 1, REJECT}, {4, 1, REJECT}, {4, 1, REJECT}};
static const nf_field SURVEY_FIELDS[] = {
    {2, 0, REJECT}, {2, 0, REJECT}, {2, 0, REJECT}, {4, 0, WRAP}, {4, 1, WRAP}, {4, 1, WRAP},
    {2, 0, SATURATE}, {2, 0, SATURATE}};
static const nf_field ENC_REQUEST_FIELDS[] = {{2, 0, REJECT}, {2, 0, WRAP}};
static const nf_field ENC_REPLY_FIELDS[] = {{2, 0, REJECT}, {2, 0, WRAP}, {4, 0, WRAP}, {4, 1, WRAP}, {4, 1, REJECT}};

static const nf_field *layout(int32_t kind, int32_t *n_fields) {
    switch (kind) {
    case NF_FRAME_ESTIMATE: *n_fields = 7; return ESTIMATE_FIELDS;
    case NF_FRAME_SURVEY: *n_fields = 8; return SURVEY_FIELDS;
    case NF_FRAME_ENC_REQUEST: *n_fields = 2; return ENC_REQUEST_FIELDS;
    case NF_FRAME_ENC_REPLY: *n_fields = 5; return ENC_REPLY_FIELDS;
    default: *n_fields = 0; return 0;
    }
}

/* MSB-first polynomial division, one bit at a time (the model uses a table: two implementations). */
uint16_t nf_crc16(const uint8_t *buf, int32_t n) {
    uint16_t c = 0xFFFFu;
    int32_t i, b;
    for (i = 0; i < n; i++) {
        c = (uint16_t)(c ^ ((uint16_t)buf[i] << 8));
        for (b = 0; b < 8; b++) {
            c = (c & 0x8000u) ? (uint16_t)((c << 1) ^ 0x1021u) : (uint16_t)(c << 1);
        }
    }
    return c;
}

int32_t nf_frame_length(int32_t kind) {
    int32_t n, i, len = 1 + 2;
    const nf_field *f = layout(kind, &n);
    if (!f) return -1;
    for (i = 0; i < n; i++) len += f[i].width;
    return len;
}

int32_t nf_frame_fields(int32_t kind) {
    int32_t n;
    return layout(kind, &n) ? n : -1;
}

int32_t nf_frame_encode(int32_t kind, const int64_t *values, uint8_t *out) {
    int32_t n, i, j, off = 1, n_sat = 0, len;
    uint16_t c;
    const nf_field *f = layout(kind, &n);
    if (!f) return -1000;
    out[0] = (uint8_t)kind;
    for (i = 0; i < n; i++) {
        int32_t bits = 8 * f[i].width;
        int64_t lo = f[i].is_signed ? -((int64_t)1 << (bits - 1)) : 0;
        int64_t hi = f[i].is_signed ? ((int64_t)1 << (bits - 1)) - 1 : ((int64_t)1 << bits) - 1;
        int64_t v = values[i];
        uint64_t u;
        if (v < lo || v > hi) {
            if (f[i].policy == REJECT) return -(1 + i);
            if (f[i].policy == SATURATE) {
                v = v < lo ? lo : hi;
                n_sat++;
            }
        }
        u = (uint64_t)v; /* two's complement; the low `bits` bits are v mod 2^bits */
        for (j = 0; j < f[i].width; j++) out[off + j] = (uint8_t)((u >> (8 * j)) & 0xFFu);
        off += f[i].width;
    }
    len = off + 2;
    c = nf_crc16(out, off);
    out[len - 2] = (uint8_t)(c & 0xFFu);
    out[len - 1] = (uint8_t)(c >> 8);
    return n_sat;
}

int32_t nf_frame_decode(int32_t kind, const uint8_t *in, int64_t *values) {
    int32_t n, i, j, off = 1;
    uint16_t got;
    const nf_field *f = layout(kind, &n);
    if (!f) return 0;
    for (i = 0; i < n; i++) {
        int32_t bits = 8 * f[i].width;
        uint64_t u = 0;
        for (j = 0; j < f[i].width; j++) u |= (uint64_t)in[off + j] << (8 * j);
        if (f[i].is_signed && u >= ((uint64_t)1 << (bits - 1))) {
            values[i] = (int64_t)u - ((int64_t)1 << bits);
        } else {
            values[i] = (int64_t)u;
        }
        off += f[i].width;
    }
    got = (uint16_t)((uint16_t)in[off] | ((uint16_t)in[off + 1] << 8));
    return got == nf_crc16(in, off) && in[0] == (uint8_t)kind;
}
