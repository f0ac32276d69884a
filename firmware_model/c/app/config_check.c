/* A minimal firmware image built against an exported node_config.h (nodesim firmware export-config): it runs the
 * static window, the filter start and a few predict-only ticks with the header's parameters and prints the state.
 * Build: gcc -std=c99 -Wall -Werror -fwrapv -I(dir of node_config.h) -Ifirmware_model/c
 *        firmware_model/c/app/config_check.c and every firmware_model/c source file */
#include <stdio.h>
#include "node_config.h"
#include "node_firmware.h"

int main(void)
{
    const int64_t params[NF_N_PARAMS] = NF_PARAMS_INIT;
    const int64_t fparams[NF_N_FILTER_PARAMS] = NF_FILTER_PARAMS_INIT;
    int64_t state[NF_STATE_SIZE], counts[NF_N_SITES] = {0}, in[8] = {0}, out[4] = {0};
    int k;
    nf_init_lane(state);
    for (k = 0; k < 10; k++) {
        in[NF_IN_PHASE] = k < 5 ? NF_STATIC : (k == 5 ? NF_START : NF_RUN);
        in[NF_IN_GZ] = 34 * 131; /* 1 deg/s for 34 samples at the 250 deg/s range */
        in[NF_IN_N] = 34;
        node_firmware_tick(state, params, fparams, counts, in, out);
    }
    printf("%lld %lld %lld\n", (long long)state[0], (long long)state[1], (long long)state[2]);
    return 0;
}
