/* cli/convert.c — placeholder until `volmesh convert` lands. */
#include "cli.h"

int vm_cmd_convert(int argc, char **argv) {
    (void)argc;
    (void)argv;
    return vm_cli_fail("convert: not built yet");
}
