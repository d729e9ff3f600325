/* cli/mesh.c — placeholder until the mesher lands. */
#include "cli.h"

int vm_cmd_mesh(int argc, char **argv) {
    (void)argc;
    (void)argv;
    return vm_cli_fail("mesh: not built yet");
}
