/* SPDX-License-Identifier: BSD-3-Clause */
/* cli/main.c — the volmesh program: the global options (--threads, --help, --version) and
 * the dispatch to a command (cli/CMD.c); the pieces they share: cli/args.c, cli/output.c. */
#include <string.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif
#include "cli.h"

static const char *usage =
    "usage: volmesh COMMAND [options]\n"
    "\n"
    "Meshes 3-D images (CT, MRI, label maps, simulation fields) into finite-element meshes.\n"
    "\n"
    "commands:\n"
    "  info FILE [--json]          describe a volume: dims, type, spacing, origin, direction,\n"
    "                              min/max/mean and a histogram\n"
    "  mesh FILE -o OUT.vtu ...    fill the material {f >= V} or {A <= f <= B} with tetrahedra\n"
    "  quality MESH [--json]       element quality and mesh checks of any mesh we read\n"
    "  report MESH -o REPORT.html  quality report with pictures, one self-contained page\n"
    "  convert IN OUT              convert a mesh between formats\n"
    "  denoise FILE -o OUT.nrrd    bilateral filter or anisotropic diffusion\n"
    "  spectrum FILE               contour spectrum: area, volume, gradient per isovalue\n"
    "  demo [--size N] [--shape S] mesh a built-in phantom and write the outputs here\n"
    "\n"
    "  volmesh COMMAND --help      options of one command\n"
    "  volmesh --version           version\n"
    "  volmesh --threads N COMMAND ...   run the parallel stages (denoising, spectrum, meshing,\n"
    "                              the quality pass's measures, VTU compression, mesh checks)\n"
    "                              on N threads (default: OMP_NUM_THREADS, else one per\n"
    "                              processor); results are the same for any N\n"
    "\n"
    "exit status: 0 ok, 1 a requested check failed, 2 bad input or usage\n";

/* The commands by name. */
static const struct {
    const char *name;
    int (*run)(int argc, char **argv);
} commands[] = {
    {"info", vm_cmd_info},       {"mesh", vm_cmd_mesh},         {"demo", vm_cmd_demo},
    {"report", vm_cmd_report},   {"quality", vm_cmd_quality},   {"convert", vm_cmd_convert},
    {"denoise", vm_cmd_denoise}, {"spectrum", vm_cmd_spectrum},
};

/* Runs the command argv[1] (a help, a version, or a subcommand with the rest of argv). */
int main(int argc, char **argv) {
#ifdef __GLIBC__
    /* Big arrays (a stage's working data, a part's in the quality pass) go back to the system
     * when freed: glibc would otherwise raise this threshold to the size of the first one
     * freed and keep later ones in its heaps, where freed memory stays resident. */
    mallopt(M_MMAP_THRESHOLD, 256 * 1024);
#endif
    /* Ctrl-C and kill remove the temporary files of the outputs being written (exit 130,
     * 143): nothing half-written remains, and older outputs stay as they were. */
    vm_output_remove_on_signals();
    if (argc < 2) {
        fputs(usage, stderr);
        return VM_EXIT_INPUT;
    }
    if (strcmp(argv[1], "--threads") == 0) {
        long n;
        if (argc < 3) return vm_cli_fail("--threads: give a number of threads");
        if (vm_cli_int("--threads", argv[2], 1, 1024, &n)) return VM_EXIT_INPUT;
        vm_set_threads((int)n);
        argc -= 2;
        argv += 2;
        if (argc < 2) return vm_cli_fail("--threads %ld: give a command after it", n);
    }
    const char *cmd = argv[1];
    if (vm_cli_is(cmd, "--help", "-h") || strcmp(cmd, "help") == 0) {
        fputs(usage, stdout);
        return VM_EXIT_OK;
    }
    if (vm_cli_is(cmd, "--version", "-V")) {
        printf("volmesh %s\n", vm_version());
        return VM_EXIT_OK;
    }
    for (size_t c = 0; c < sizeof commands / sizeof commands[0]; c++)
        if (strcmp(cmd, commands[c].name) == 0) return commands[c].run(argc - 1, argv + 1);
    return vm_cli_fail("unknown command '%s' (try volmesh --help)", cmd);
}
