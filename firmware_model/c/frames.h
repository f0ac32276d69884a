/* Radio frames as bytes (docs/firmware.md "Frames"): the C of firmware_model/frames.py. Little-endian, packed,
 * written and read byte by byte with explicit shifts (no struct layout, no host-endianness assumption); the
 * last two bytes are the CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection, xorout 0; check 0x29B1
 * for "123456789") of every byte before them, itself little-endian.
 * values[] holds the payload fields in wire order (the type byte and the CRC are not values):
 *   NF_FRAME_ESTIMATE    node u16, seq u16, t_read_us u32, yaw i32, P_yy i32, rate i32, bias i32      27 bytes
 *   NF_FRAME_SURVEY      station u16, node u16, cluster u16, t_us u32, I i32, A i32, sigma_I u16,
 *                        sigma_A u16                                                                  25 bytes
 *   NF_FRAME_ENC_REQUEST node u16, seq u16                                                             7 bytes
 *   NF_FRAME_ENC_REPLY   node u16, seq u16, t_read_us u32, yaw i32, rate i32                           19 bytes
 * Out-of-range values: seq, times and binary angles wrap (mod 2^bits); sigma_I/sigma_A saturate (counted in
 * the return value); any other field out of range rejects the frame (return -(1 + field index)). */
#ifndef NF_FRAMES_H
#define NF_FRAMES_H
#include <stdint.h>

#define NF_FRAME_ESTIMATE 1
#define NF_FRAME_SURVEY 2
#define NF_FRAME_ENC_REQUEST 3
#define NF_FRAME_ENC_REPLY 4
#define NF_FRAME_ESTIMATE_BYTES 27
#define NF_FRAME_SURVEY_BYTES 25
#define NF_FRAME_ENC_REQUEST_BYTES 7
#define NF_FRAME_ENC_REPLY_BYTES 19
#define NF_FRAME_MAX_BYTES 27

/* cdef-begin */
uint16_t nf_crc16(const uint8_t *buf, int32_t n);
int32_t nf_frame_length(int32_t kind);
int32_t nf_frame_fields(int32_t kind);
int32_t nf_frame_encode(int32_t kind, const int64_t *values, uint8_t *out);
int32_t nf_frame_decode(int32_t kind, const uint8_t *in, int64_t *values);
/* cdef-end */

#endif
