#ifndef PSMAT_PSM_HAL_H
#define PSMAT_PSM_HAL_H
#include "psm_core.h"
extern const psm_hal bluepill_psm_hal;
#endif
