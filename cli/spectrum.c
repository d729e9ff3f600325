/* cli/spectrum.c — placeholder until `volmesh spectrum` lands. */
#include "cli.h"

int vm_cmd_spectrum(int argc, char **argv) {
    (void)argc;
    (void)argv;
    return vm_cli_fail("spectrum: not built yet");
}
