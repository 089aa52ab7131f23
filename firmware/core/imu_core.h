/* Spine IMU DAQ (docs/spec.md §5, docs/protocol.md "Spine IMU DAQ"): 5 BNO055, Euler angles in
 * degrees as float32, v1 or v2 framing, 10 Hz by default, streaming from power-up; the
 * PSM command set minus CAL_HOLD (answered "unknown opcode"). */
#ifndef PSMAT_IMU_CORE_H
#define PSMAT_IMU_CORE_H

#include <stddef.h>
#include <stdint.h>

#include "command.h"
#include "device.h"
#include "frame.h"

#define IMU_FW_VERSION "0.1.0"
#define IMU_DEFAULT_RATE_HZ 10u
#define IMU_RATE_MIN 1u
#define IMU_RATE_MAX 100u /* the BNO055 fusion output rate */
#define IMU_SERIAL_MAX PM_DEV_SERIAL_MAX

typedef struct imu_hal {
    void *ctx;
    /* heading, roll, pitch of sensor 0..4 in degrees (NaN where the sensor failed) */
    void (*read_euler)(void *ctx, uint8_t sensor, float hrp[3]);
    void (*write)(void *ctx, const uint8_t *data, size_t n);
    uint32_t (*micros)(void *ctx);
    void (*set_rate)(void *ctx, uint32_t hz); /* retime the tick */
} imu_hal;

typedef struct imu_core {
    imu_hal hal;
    pm_device dev; /* protocol, streaming, rate_hz, seq, serial, parser, reply */
    float angles[IMU_ANGLES]; /* last read, sensor-major */
    uint8_t frame[PM_V2_LEN(IMU_PAYLOAD_LEN)];
} imu_core;

void imu_init(imu_core *c, const imu_hal *hal, uint8_t protocol, const char *serial);
void imu_on_tick(imu_core *c); /* read the 5 sensors, encode, write if streaming */
void imu_on_rx(imu_core *c, const uint8_t *data, size_t n);

#endif
