#include "node_firmware.h"

int32_t nf_abi_version(void) { return 1; }
