/* Frame encoders, byte-exact to docs/protocol.md (docs/spec.md §5). All integers little-endian,
 * cells row-major a = i*C + p. Every encoder returns the number of bytes written. */
#ifndef PSMAT_FRAME_H
#define PSMAT_FRAME_H

#include <stddef.h>
#include <stdint.h>

#define PM_PROTO_V1 1u
#define PM_PROTO_V2 2u

/* v1 (thesis Code 2.1-2.2): INIT INIT | cells LE | (sum mod 4096) LE */
#define PSM_V1_INIT 0xFFu
#define PSM_V1_LEN(n_cells) (4u + 2u * (n_cells))
#define PM_CHECK_MOD 4096u

/* v2 header: sync(2) version(1) type(1) seq(4) t_us(4) rows(1) cols(1) n(2) */
#define PM_SYNC0 0xA5u
#define PM_SYNC1 0x5Au
#define PM_VERSION 2u
#define PM_TYPE_PSM 0x01u
#define PM_TYPE_IMU 0x02u
#define PM_TYPE_COMMAND 0x10u
#define PM_TYPE_REPLY 0x11u
#define PM_HEADER_LEN 16u
#define PM_MAX_PAYLOAD 8192u
#define PM_V2_LEN(n) (PM_HEADER_LEN + (n) + 2u)

/* IMU: 5 sensors x (heading, roll, pitch) float32 degrees, sensor-major */
#define IMU_SENSORS 5u
#define IMU_ANGLES (3u * IMU_SENSORS)
#define IMU_PAYLOAD_LEN (4u * IMU_ANGLES)
#define IMU_V1_LEN (4u + IMU_PAYLOAD_LEN)

void pm_put_u16le(uint8_t *out, uint16_t v);
void pm_put_u32le(uint8_t *out, uint32_t v);

/* v1 PSM frame; cells must be 12-bit (high byte <= 0x0F) so 0xFF 0xFF stays unique. */
size_t psm_encode_v1(const uint16_t *cells, size_t n_cells, uint8_t *out);

/* v2 packet with `n` payload bytes copied from `payload` (which must not overlap `out`). */
size_t pm_encode_v2(uint8_t type, uint32_t seq, uint32_t t_us, uint8_t rows, uint8_t cols,
                    const uint8_t *payload, uint16_t n, uint8_t *out);

/* v2 packet whose n payload bytes are already at out + PM_HEADER_LEN: writes the header
 * and the CRC around them. The building block of every v2 encoder. */
size_t pm_v2_seal(uint8_t type, uint32_t seq, uint32_t t_us, uint8_t rows, uint8_t cols,
                  uint16_t n, uint8_t *out);

/* v2 PSM frame (type 0x01) straight from the cell array: 16 + 2*R*C + 2 bytes. */
size_t psm_encode_v2(uint32_t seq, uint32_t t_us, uint8_t rows, uint8_t cols,
                     const uint16_t *cells, uint8_t *out);

/* IMU v1: INIT INIT | 60 payload bytes | (sum of 30 LE uint16 words mod 4096) LE */
size_t imu_encode_v1(const float angles[IMU_ANGLES], uint8_t *out);
/* IMU v2: type 0x02, rows 5, cols 3, n 60 */
size_t imu_encode_v2(uint32_t seq, uint32_t t_us, const float angles[IMU_ANGLES], uint8_t *out);

#endif
