#include "frame.h"

#include "crc16.h"

void pm_put_u16le(uint8_t *out, uint16_t v)
{
    out[0] = (uint8_t)v;
    out[1] = (uint8_t)(v >> 8);
}

void pm_put_u32le(uint8_t *out, uint32_t v)
{
    pm_put_u16le(out, (uint16_t)v);
    pm_put_u16le(out + 2, (uint16_t)(v >> 16));
}

size_t psm_encode_v1(const uint16_t *cells, size_t n_cells, uint8_t *out)
{
    uint32_t sum = 0;
    out[0] = PSM_V1_INIT;
    out[1] = PSM_V1_INIT;
    for (size_t a = 0; a < n_cells; a++) {
        pm_put_u16le(out + 2 + 2 * a, cells[a]);
        sum += cells[a];
    }
    pm_put_u16le(out + 2 + 2 * n_cells, (uint16_t)(sum % PM_CHECK_MOD));
    return PSM_V1_LEN(n_cells);
}

size_t pm_v2_seal(uint8_t type, uint32_t seq, uint32_t t_us, uint8_t rows, uint8_t cols,
                  uint16_t n, uint8_t *out)
{
    out[0] = PM_SYNC0;
    out[1] = PM_SYNC1;
    out[2] = PM_VERSION;
    out[3] = type;
    pm_put_u32le(out + 4, seq);
    pm_put_u32le(out + 8, t_us);
    out[12] = rows;
    out[13] = cols;
    pm_put_u16le(out + 14, n);
    /* CRC over everything after the sync: bytes [2, 16 + n) */
    pm_put_u16le(out + PM_HEADER_LEN + n, pm_crc16(out + 2, PM_HEADER_LEN - 2u + n));
    return PM_V2_LEN((size_t)n);
}

size_t pm_encode_v2(uint8_t type, uint32_t seq, uint32_t t_us, uint8_t rows, uint8_t cols,
                    const uint8_t *payload, uint16_t n, uint8_t *out)
{
    for (uint16_t k = 0; k < n; k++)
        out[PM_HEADER_LEN + k] = payload[k];
    return pm_v2_seal(type, seq, t_us, rows, cols, n, out);
}

size_t psm_encode_v2(uint32_t seq, uint32_t t_us, uint8_t rows, uint8_t cols,
                     const uint16_t *cells, uint8_t *out)
{
    size_t n_cells = (size_t)rows * cols;
    for (size_t a = 0; a < n_cells; a++)
        pm_put_u16le(out + PM_HEADER_LEN + 2 * a, cells[a]);
    return pm_v2_seal(PM_TYPE_PSM, seq, t_us, rows, cols, (uint16_t)(2 * n_cells), out);
}

/* IEEE-754 binary32 bits of f, written LE whatever the host byte order. */
static void put_f32le(uint8_t *out, float f)
{
    union { float f; uint32_t u; } bits;
    bits.f = f;
    pm_put_u32le(out, bits.u);
}

static void put_angles(const float angles[IMU_ANGLES], uint8_t *out)
{
    for (unsigned k = 0; k < IMU_ANGLES; k++)
        put_f32le(out + 4 * k, angles[k]);
}

size_t imu_encode_v1(const float angles[IMU_ANGLES], uint8_t *out)
{
    uint32_t sum = 0;
    out[0] = PSM_V1_INIT;
    out[1] = PSM_V1_INIT;
    put_angles(angles, out + 2);
    for (unsigned w = 0; w < IMU_PAYLOAD_LEN / 2; w++)
        sum += (uint32_t)out[2 + 2 * w] | ((uint32_t)out[3 + 2 * w] << 8);
    pm_put_u16le(out + 2 + IMU_PAYLOAD_LEN, (uint16_t)(sum % PM_CHECK_MOD));
    return IMU_V1_LEN;
}

size_t imu_encode_v2(uint32_t seq, uint32_t t_us, const float angles[IMU_ANGLES], uint8_t *out)
{
    put_angles(angles, out + PM_HEADER_LEN);
    return pm_v2_seal(PM_TYPE_IMU, seq, t_us, IMU_SENSORS, 3, IMU_PAYLOAD_LEN, out);
}
