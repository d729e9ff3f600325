/* cli/quality.c — placeholder until `volmesh quality` lands. */
#include "cli.h"

int vm_cmd_quality(int argc, char **argv) {
    (void)argc;
    (void)argv;
    return vm_cli_fail("quality: not built yet");
}
