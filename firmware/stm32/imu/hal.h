#ifndef PSMAT_IMU_HAL_H
#define PSMAT_IMU_HAL_H
#include "imu_core.h"
extern const imu_hal bluepill_imu_hal;
/* Sets up the three buses and the five BNO055 (after their boot time). */
void hal_sensors_init(void);
#endif
