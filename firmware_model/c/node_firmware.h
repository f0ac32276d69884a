/* The node firmware's entry point (docs/firmware.md): one call per firmware tick over a state struct. */
#ifndef NODE_FIRMWARE_H
#define NODE_FIRMWARE_H
#include <stdint.h>

/* cdef-begin */
int32_t nf_abi_version(void);
/* cdef-end */

#endif
