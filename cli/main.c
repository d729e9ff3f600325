/* cli/main.c — the volmesh program: subcommand dispatch, shared option parsing, errors. */
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
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

int vm_cli_fail(const char *fmt, ...) {
    va_list ap;
    fputs("volmesh: ", stderr);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    return VM_EXIT_INPUT;
}

int vm_cli_fail_err(const vm_error *err) {
    return vm_cli_fail("%s", err->message[0] ? err->message : vm_status_string(err->status));
}

int vm_cli_is(const char *a, const char *flag1, const char *flag2) {
    return (flag1 && strcmp(a, flag1) == 0) || (flag2 && strcmp(a, flag2) == 0);
}

int vm_cli_double(const char *opt, const char *s, double *out) {
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (end == s || *end || errno == ERANGE || !isfinite(v)) {
        vm_cli_fail("%s: '%s' is not a number", opt, s);
        return -1;
    }
    *out = v;
    return 0;
}

int vm_cli_int(const char *opt, const char *s, long lo, long hi, long *out) {
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (end == s || *end || errno == ERANGE || v < lo || v > hi) {
        vm_cli_fail("%s: '%s' is not a whole number from %ld to %ld", opt, s, lo, hi);
        return -1;
    }
    *out = v;
    return 0;
}

int vm_cli_ends_with(const char *s, const char *tail) {
    size_t n = strlen(s), t = strlen(tail);
    if (n < t) return 0;
    for (size_t i = 0; i < t; i++)
        if (tolower((unsigned char)s[n - t + i]) != tolower((unsigned char)tail[i])) return 0;
    return 1;
}

int vm_cli_fail_mesh_read(const char *path, const vm_error *err) {
    static const char *const volume_tails[] = {".nrrd", ".nhdr", ".nii", ".nii.gz", ".hdr",
                                               ".img",  ".mha",  ".mhd", ".vti",    ".raw"};
    int volume = strstr(err->message, "STRUCTURED_POINTS") != NULL;
    for (size_t i = 0; i < sizeof volume_tails / sizeof volume_tails[0]; i++)
        volume |= vm_cli_ends_with(path, volume_tails[i]);
    if (!volume) return vm_cli_fail_err(err);
    return vm_cli_fail("%s: this is an image volume, not a mesh: mesh it first "
                       "(volmesh mesh %s --iso V -o OUT.vtu)",
                       path, path);
}

int vm_cli_need_value(const char *cmd, int i, int argc, char **argv) {
    const char *opt = argv[i];
    if (i + 1 >= argc) return vm_cli_fail("%s: %s needs a value", cmd, opt);
    const char *v = argv[i + 1];
    int looks_like_option = v[0] == '-' && v[1] != 0 && !isdigit((unsigned char)v[1]) && v[1] != '.';
    if (looks_like_option)
        return vm_cli_fail("%s: %s needs a value (found the option '%s' in its place)", cmd, opt, v);
    return 0;
}

void vm_cli_status(const char *what, const char *name, int quiet) {
    if (quiet || !isatty(2)) return;
    fprintf(stderr, "\r\033[K%s %s ...", what, name);
    fflush(stderr);
}

void vm_cli_status_clear(int quiet) {
    if (quiet || !isatty(2)) return;
    fputs("\r\033[K", stderr);
    fflush(stderr);
}

void vm_cli_progress(const char *stage, double done, double total, void *user) {
    int quiet = user ? *(const int *)user : 0;
    if (quiet || !isatty(2) || total <= 0) return;
    int width = 30, fill = (int)(width * (done / total) + 0.5);
    if (fill > width) fill = width;
    fprintf(stderr, "\r%-12s [%.*s%*s] %3d%%", stage, fill, "##############################",
            width - fill, "", (int)(100.0 * done / total + 0.5));
    if (done >= total) fputs("\r\033[K", stderr);
    fflush(stderr);
}

int main(int argc, char **argv) {
#ifdef __GLIBC__
    /* Big arrays (a stage's working data, a part's in the quality pass) go back to the system
     * when freed: glibc would otherwise raise this threshold to the size of the first one
     * freed and keep later ones in its heaps, where freed memory stays resident. */
    mallopt(M_MMAP_THRESHOLD, 256 * 1024);
#endif
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
    if (strcmp(cmd, "info") == 0) return vm_cmd_info(argc - 1, argv + 1);
    if (strcmp(cmd, "mesh") == 0) return vm_cmd_mesh(argc - 1, argv + 1);
    if (strcmp(cmd, "demo") == 0) return vm_cmd_demo(argc - 1, argv + 1);
    if (strcmp(cmd, "report") == 0) return vm_cmd_report(argc - 1, argv + 1);
    if (strcmp(cmd, "quality") == 0) return vm_cmd_quality(argc - 1, argv + 1);
    if (strcmp(cmd, "convert") == 0) return vm_cmd_convert(argc - 1, argv + 1);
    if (strcmp(cmd, "denoise") == 0) return vm_cmd_denoise(argc - 1, argv + 1);
    if (strcmp(cmd, "spectrum") == 0) return vm_cmd_spectrum(argc - 1, argv + 1);
    vm_cli_fail("unknown command '%s' (try volmesh --help)", cmd);
    return VM_EXIT_INPUT;
}
