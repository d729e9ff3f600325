/* cli/denoise.c — placeholder until `volmesh denoise` lands. */
#include "cli.h"

int vm_cmd_denoise(int argc, char **argv) {
    (void)argc;
    (void)argv;
    return vm_cli_fail("denoise: not built yet");
}
