/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_volume_slab.c — reading volumes by slabs: for every format and encoding,
 * the slabs concatenated along z equal the whole read value for value, each slab's origin is
 * the world position of its first plane, the header-only read has the whole dims, and bad
 * ranges, truncated data and lying headers give one-line errors; a forward reader reads the
 * same planes into the caller's buffer and goes on in a gzip stream or ASCII text where its
 * previous slab ended. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <zlib.h>
#include "test.h"

enum { NX = 7, NY = 5, NZ = 6, N = NX * NY * NZ };

static double value(int i, int j, int k) { return i + 10 * j + 100 * k + 0.25; }

static void put_f32(unsigned char *p, float x, int big) {
    unsigned char b[4];
    memcpy(b, &x, 4);
    uint32_t one = 1;
    int host_big = *(unsigned char *)&one == 0;
    for (int i = 0; i < 4; i++) p[i] = host_big == big ? b[i] : b[3 - i];
}

/* The samples as float32 in the byte order asked. */
static unsigned char *samples(int big) {
    unsigned char *b = malloc(4 * N);
    for (int k = 0; k < NZ; k++)
        for (int j = 0; j < NY; j++)
            for (int i = 0; i < NX; i++)
                put_f32(b + 4 * (i + NX * (j + NY * k)), (float)value(i, j, k), big);
    return b;
}

static char *ascii_samples(void) {
    char *t = malloc(32 * N), *p = t;
    for (int k = 0; k < NZ; k++)
        for (int j = 0; j < NY; j++)
            for (int i = 0; i < NX; i++) p += sprintf(p, "%g%s", value(i, j, k), i + 1 < NX ? " " : "\n");
    return t;
}

static size_t cat(unsigned char *dst, const void *src, size_t n) {
    memcpy(dst, src, n);
    return n;
}

static void write_gz(const char *path, const void *data, size_t n) {
    gzFile g = gzopen(path, "wb");
    CHECK(g != NULL);
    if (!g) return;
    CHECK(gzwrite(g, data, (unsigned)n) == (int)n);
    gzclose(g);
}

static const char *nrrd_header =
    "NRRD0004\ntype: float\ndimension: 3\nsizes: 7 5 6\nendian: %s\nencoding: %s\n"
    "space dimension: 3\nspace directions: (0,0.5,0) (-2,0,0) (0,0,1.5)\n"
    "space origin: (1,2,3)\n%s\n";

static void make_files(void) {
    unsigned char *le = samples(0), *be = samples(1);
    char *txt = ascii_samples();
    unsigned char *buf = malloc(16 * N + 4096);
    char hdr[1024];
    size_t at;

    snprintf(hdr, sizeof hdr, nrrd_header, "little", "raw", "");
    at = cat(buf, hdr, strlen(hdr));
    at += cat(buf + at, le, 4 * N);
    vm_test_write_file(vm_test_tmp("slab_raw.nrrd"), buf, at);

    snprintf(hdr, sizeof hdr, nrrd_header, "big", "raw", "byte skip: 3\n");
    at = cat(buf, hdr, strlen(hdr));
    at += cat(buf + at, "xyz", 3);
    at += cat(buf + at, be, 4 * N);
    vm_test_write_file(vm_test_tmp("slab_big.nrrd"), buf, at);

    snprintf(hdr, sizeof hdr, nrrd_header, "little", "ascii", "");
    at = cat(buf, hdr, strlen(hdr));
    at += cat(buf + at, txt, strlen(txt));
    vm_test_write_file(vm_test_tmp("slab_ascii.nrrd"), buf, at);

    snprintf(hdr, sizeof hdr, nrrd_header, "little", "gzip", "data file: slab_det.raw.gz\n");
    vm_test_write_file(vm_test_tmp("slab_det.nhdr"), hdr, strlen(hdr));
    write_gz(vm_test_tmp("slab_det.raw.gz"), le, 4 * N);

    /* NIfTI-1 with scaling 2x + 1, single file, plain and gzipped, and a .hdr/.img pair */
    unsigned char nh[352];
    memset(nh, 0, sizeof nh);
    int32_t i32 = 348;
    memcpy(nh, &i32, 4);
    int16_t dim[8] = {3, NX, NY, NZ, 1, 1, 1, 1}, dt = 16, bp = 32;
    memcpy(nh + 40, dim, sizeof dim);
    memcpy(nh + 70, &dt, 2);
    memcpy(nh + 72, &bp, 2);
    float pix[8] = {1, 0.5f, 2, 1.5f, 1, 1, 1, 1}, f;
    memcpy(nh + 76, pix, sizeof pix);
    f = 352;
    memcpy(nh + 108, &f, 4);
    f = 2;
    memcpy(nh + 112, &f, 4);
    f = 1;
    memcpy(nh + 116, &f, 4);
    memcpy(nh + 344, "n+1", 4);
    unsigned char *host = samples(*(unsigned char *)&i32 == 0);
    at = cat(buf, nh, sizeof nh);
    at += cat(buf + at, host, 4 * N);
    vm_test_write_file(vm_test_tmp("slab.nii"), buf, at);
    write_gz(vm_test_tmp("slab.nii.gz"), buf, at);
    memcpy(nh + 344, "ni1", 4);
    f = 0;
    memcpy(nh + 108, &f, 4);
    vm_test_write_file(vm_test_tmp("slab_pair.hdr"), nh, 348);
    write_gz(vm_test_tmp("slab_pair.img.gz"), host, 4 * N);

    /* MetaImage, raw and compressed */
    const char *mh = "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = "
                     "False\n%sDimSize = 7 5 6\nElementSpacing = 0.5 2 1.5\nOffset = 1 2 3\n"
                     "ElementType = MET_FLOAT\nElementDataFile = LOCAL\n";
    snprintf(hdr, sizeof hdr, mh, "");
    at = cat(buf, hdr, strlen(hdr));
    at += cat(buf + at, le, 4 * N);
    vm_test_write_file(vm_test_tmp("slab.mha"), buf, at);
    uLongf clen = compressBound(4 * N);
    unsigned char *z = malloc(clen);
    CHECK(compress2(z, &clen, le, 4 * N, 6) == Z_OK);
    char extra[128];
    snprintf(extra, sizeof extra, "CompressedData = True\nCompressedDataSize = %lu\n",
             (unsigned long)clen);
    snprintf(hdr, sizeof hdr, mh, extra);
    at = cat(buf, hdr, strlen(hdr));
    at += cat(buf + at, z, clen);
    vm_test_write_file(vm_test_tmp("slab_z.mha"), buf, at);

    /* VTK legacy, binary (big endian) and ASCII */
    const char *vh = "# vtk DataFile Version 3.0\nslab\n%s\nDATASET STRUCTURED_POINTS\n"
                     "DIMENSIONS 7 5 6\nSPACING 0.5 2 -1.5\nORIGIN 1 2 3\nPOINT_DATA 210\n"
                     "SCALARS f float 1\nLOOKUP_TABLE default\n";
    snprintf(hdr, sizeof hdr, vh, "BINARY");
    at = cat(buf, hdr, strlen(hdr));
    at += cat(buf + at, be, 4 * N);
    vm_test_write_file(vm_test_tmp("slab_bin.vtk"), buf, at);
    snprintf(hdr, sizeof hdr, vh, "ASCII");
    at = cat(buf, hdr, strlen(hdr));
    at += cat(buf + at, txt, strlen(txt));
    vm_test_write_file(vm_test_tmp("slab_ascii.vtk"), buf, at);

    /* VTI: appended raw, inline ascii */
    const char *xh = "<?xml version=\"1.0\"?>\n<VTKFile type=\"ImageData\" version=\"1.0\" "
                     "byte_order=\"LittleEndian\" header_type=\"UInt64\">\n<ImageData "
                     "WholeExtent=\"0 6 0 4 2 7\" Origin=\"1 2 3\" Spacing=\"0.5 2 1.5\">\n"
                     "<Piece Extent=\"0 6 0 4 2 7\">\n<PointData Scalars=\"f\">\n";
    at = cat(buf, xh, strlen(xh));
    const char *a1 = "<DataArray type=\"Float32\" Name=\"f\" format=\"appended\" offset=\"0\"/>\n"
                     "</PointData>\n</Piece>\n</ImageData>\n<AppendedData encoding=\"raw\">\n_";
    at += cat(buf + at, a1, strlen(a1));
    uint64_t nb = 4 * N;
    at += cat(buf + at, &nb, 8);
    at += cat(buf + at, le, 4 * N);
    const char *a2 = "\n</AppendedData>\n</VTKFile>\n";
    at += cat(buf + at, a2, strlen(a2));
    vm_test_write_file(vm_test_tmp("slab_app.vti"), buf, at);
    at = cat(buf, xh, strlen(xh));
    const char *b1 = "<DataArray type=\"Float32\" Name=\"f\" format=\"ascii\">\n";
    at += cat(buf + at, b1, strlen(b1));
    at += cat(buf + at, txt, strlen(txt));
    const char *b2 = "</DataArray>\n</PointData>\n</Piece>\n</ImageData>\n</VTKFile>\n";
    at += cat(buf + at, b2, strlen(b2));
    vm_test_write_file(vm_test_tmp("slab_ascii.vti"), buf, at);

    /* gzip NRRD written by volmesh itself */
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read(vm_test_tmp("slab_raw.nrrd"), &v, &err), &err);
    if (v.data) CHECK_OK(vm_volume_write_nrrd(vm_test_tmp("slab_gz.nrrd"), &v, 1, &err), &err);
    vm_volume_free(&v);

    /* raw */
    vm_test_write_file(vm_test_tmp("slab.raw"), le, 4 * N);
    free(le);
    free(be);
    free(host);
    free(txt);
    free(buf);
    free(z);
}

/* The description of slab.raw: NX x NY x NZ float32, little endian. */
static void raw_options(vm_raw_options *o) {
    memset(o, 0, sizeof *o);
    o->dims[0] = NX;
    o->dims[1] = NY;
    o->dims[2] = NZ;
    o->type = VM_SCALAR_FLOAT32;
}

static const char *const files[] = {
    "slab_raw.nrrd", "slab_big.nrrd",     "slab_ascii.nrrd", "slab_det.nhdr",
    "slab_gz.nrrd",  "slab.nii",          "slab.nii.gz",     "slab_pair.hdr",
    "slab.mha",      "slab_z.mha",        "slab_bin.vtk",    "slab_ascii.vtk",
    "slab_app.vti",  "slab_ascii.vti",
};

/* Slab [z0, z1) of whole: same values, dims nx ny z1-z0, origin at plane z0. */
static void check_slab(const char *name, const vm_volume *whole, const vm_volume *s,
                       int64_t z0, int64_t z1) {
    CHECK(s->dims[0] == whole->dims[0] && s->dims[1] == whole->dims[1] &&
          s->dims[2] == z1 - z0);
    CHECK(s->type == whole->type && strcmp(s->format, whole->format) == 0);
    double ijk[3] = {0, 0, (double)z0}, o[3];
    vm_volume_index_to_world(whole, ijk, o);
    for (int a = 0; a < 3; a++) {
        CHECK(fabs(s->origin[a] - o[a]) < 1e-12);
        CHECK(s->spacing[a] == whole->spacing[a]);
        for (int b = 0; b < 3; b++) CHECK(s->direction[a][b] == whole->direction[a][b]);
    }
    size_t plane = (size_t)whole->dims[0] * (size_t)whole->dims[1];
    size_t bad = 0;
    for (size_t i = 0; i < plane * (size_t)(z1 - z0); i++)
        if (memcmp(&s->data[i], &whole->data[plane * (size_t)z0 + i], sizeof(float)) != 0) bad++;
    if (bad) fprintf(stderr, "  %s: slab %lld..%lld differs in %zu values\n", name,
                     (long long)z0, (long long)z1, bad);
    CHECK(bad == 0);
}

static void slabsConcatenatedEqualTheWholeReadInEveryFormat(void) {
    make_files();
    for (size_t f = 0; f < sizeof files / sizeof files[0]; f++) {
        const char *path = vm_test_tmp(files[f]);
        vm_volume whole, info;
        vm_error err;
        vm_error_clear(&err);
        CHECK_OK(vm_volume_read(path, &whole, &err), &err);
        if (!whole.data) continue;
        CHECK(whole.dims[0] == NX && whole.dims[1] == NY && whole.dims[2] == NZ);
        /* the data itself, to be sure the whole read is right (NIfTI scales 2x + 1) */
        int nifti = strcmp(whole.format, "nifti") == 0;
        size_t wrong = 0;
        for (int k = 0; k < NZ; k++)
            for (int j = 0; j < NY; j++)
                for (int i = 0; i < NX; i++) {
                    double x = value(i, j, k);
                    if (nifti) x = 2 * x + 1;
                    if (whole.data[i + NX * (j + NY * k)] != (float)x) wrong++;
                }
        if (wrong) fprintf(stderr, "  %s: %zu wrong values\n", files[f], wrong);
        CHECK(wrong == 0);
        CHECK_OK(vm_volume_read_info(path, &info, &err), &err);
        CHECK(info.data == NULL);
        CHECK(memcmp(info.dims, whole.dims, sizeof info.dims) == 0);
        CHECK(memcmp(info.origin, whole.origin, sizeof info.origin) == 0);
        CHECK(memcmp(info.spacing, whole.spacing, sizeof info.spacing) == 0);
        CHECK(memcmp(info.direction, whole.direction, sizeof info.direction) == 0);
        vm_volume_free(&info);
        static const int64_t cuts[][2] = {{0, 2}, {2, 3}, {3, 6}, {0, 6}, {5, 6}, {0, 1}};
        for (size_t c = 0; c < sizeof cuts / sizeof cuts[0]; c++) {
            vm_volume s;
            CHECK_OK(vm_volume_read_slab(path, cuts[c][0], cuts[c][1], &s, &err), &err);
            if (s.data) check_slab(files[f], &whole, &s, cuts[c][0], cuts[c][1]);
            vm_volume_free(&s);
        }
        vm_volume_free(&whole);
    }
    /* raw */
    vm_raw_options o;
    raw_options(&o);
    o.spacing[2] = 3;
    vm_volume whole, s, info;
    vm_error err;
    const char *path = vm_test_tmp("slab.raw");
    CHECK_OK(vm_volume_read_raw(path, &o, &whole, &err), &err);
    CHECK_OK(vm_volume_read_raw_info(path, &o, &info, &err), &err);
    CHECK(info.data == NULL && info.dims[2] == NZ);
    CHECK_OK(vm_volume_read_raw_slab(path, &o, 1, 4, &s, &err), &err);
    if (whole.data && s.data) check_slab("slab.raw", &whole, &s, 1, 4);
    vm_volume_free(&whole);
    vm_volume_free(&s);
}

/* Big enough for the threaded conversion (blocks of 2^16 samples), int16 big endian. */
static void slabsOfAThreadedConversionEqualTheWholeRead(void) {
    int n = getenv("VM_SANITIZED") ? 40 : 80;
    size_t count = (size_t)64 * 64 * (size_t)n;
    char hdr[256];
    snprintf(hdr, sizeof hdr, "NRRD0004\ntype: short\ndimension: 3\nsizes: 64 64 %d\n"
             "endian: big\nencoding: raw\n\n", n);
    size_t hl = strlen(hdr);
    unsigned char *buf = malloc(hl + 2 * count);
    memcpy(buf, hdr, hl);
    for (size_t i = 0; i < count; i++) {
        int16_t x = (int16_t)((i * 7919) % 65536 - 32768);
        buf[hl + 2 * i] = (unsigned char)((uint16_t)x >> 8);
        buf[hl + 2 * i + 1] = (unsigned char)((uint16_t)x & 255);
    }
    const char *path = vm_test_tmp("slab_threads.nrrd");
    CHECK(vm_test_write_file(path, buf, hl + 2 * count) == 0);
    free(buf);
    vm_volume whole;
    vm_error err;
    CHECK_OK(vm_volume_read(path, &whole, &err), &err);
    if (!whole.data) return;
    size_t wrong = 0;
    for (size_t i = 0; i < count; i++)
        if (whole.data[i] != (float)(int16_t)((i * 7919) % 65536 - 32768)) wrong++;
    CHECK(wrong == 0);
    for (int z0 = 0; z0 < n; z0 += 13) {
        int z1 = z0 + 13 < n ? z0 + 13 : n;
        vm_volume s;
        CHECK_OK(vm_volume_read_slab(path, z0, z1, &s, &err), &err);
        if (s.data) check_slab("slab_threads.nrrd", &whole, &s, z0, z1);
        vm_volume_free(&s);
    }
    vm_volume_free(&whole);
}

static void expect_slab_error(const char *path, int64_t z0, int64_t z1, vm_status want,
                              const char *text) {
    vm_volume s;
    vm_error err;
    vm_error_clear(&err);
    vm_status st = vm_volume_read_slab(path, z0, z1, &s, &err);
    CHECK(st == want);
    CHECK(s.data == NULL);
    CHECK(strstr(err.message, path) == err.message);
    CHECK(strchr(err.message, '\n') == NULL);
    if (!strstr(err.message, text))
        fprintf(stderr, "  %s %lld..%lld: got '%s', want '%s'\n", path, (long long)z0,
                (long long)z1, err.message, text);
    CHECK(strstr(err.message, text) != NULL);
    vm_volume_free(&s);
}

static void slabReadsRefuseBadRangesTruncatedDataAndLyingHeaders(void) {
    make_files();
    for (size_t f = 0; f < sizeof files / sizeof files[0]; f++) {
        const char *path = vm_test_tmp(files[f]);
        expect_slab_error(path, -1, 2, VM_ERR_ARG, "outside the volume's planes 0..5");
        expect_slab_error(path, 3, 3, VM_ERR_ARG, "outside");
        expect_slab_error(path, 4, 7, VM_ERR_ARG, "outside");
    }
    /* a gzip NRRD cut short: the slabs past the cut say so */
    unsigned char *gz;
    FILE *fp = fopen(vm_test_tmp("slab_gz.nrrd"), "rb");
    CHECK(fp != NULL);
    if (!fp) return;
    gz = malloc(1 << 16);
    size_t len = fread(gz, 1, 1 << 16, fp);
    fclose(fp);
    vm_test_write_file(vm_test_tmp("slab_gzcut.nrrd"), gz, len - 40);
    expect_slab_error(vm_test_tmp("slab_gzcut.nrrd"), 4, 6, VM_ERR_FORMAT,
                      "compressed data is truncated");
    /* a raw NRRD whose header promises more planes than the file has: even the first
     * plane is refused (the size is checked against the file, as in a whole read) */
    fp = fopen(vm_test_tmp("slab_raw.nrrd"), "rb");
    len = fread(gz, 1, 1 << 16, fp);
    fclose(fp);
    vm_test_write_file(vm_test_tmp("slab_rawcut.nrrd"), gz, len - 4);
    expect_slab_error(vm_test_tmp("slab_rawcut.nrrd"), 0, 1, VM_ERR_FORMAT,
                      "data is truncated (836 of 840 bytes)");
    free(gz);
    /* ASCII with too few values: the last slab runs out */
    const char *a = "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 3\nencoding: ascii\n\n"
                    "1 2 3 4 5 6 7 8 9 10 11\n";
    vm_test_write_file(vm_test_tmp("slab_ascut.nrrd"), a, strlen(a));
    expect_slab_error(vm_test_tmp("slab_ascut.nrrd"), 2, 3, VM_ERR_FORMAT,
                      "data is truncated (11 of 12 ascii values)");
    const char *w = "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 3\nencoding: ascii\n\n"
                    "1 2 3 4 5 6 7 8 9 pear 11 12\n";
    vm_test_write_file(vm_test_tmp("slab_asbad.nrrd"), w, strlen(w));
    expect_slab_error(vm_test_tmp("slab_asbad.nrrd"), 2, 3, VM_ERR_FORMAT,
                      "ascii value 9 ('pear') is not a number");
    /* a header-only read of a file that does not exist */
    vm_volume v;
    vm_error err;
    CHECK(vm_volume_read_info(vm_test_tmp("slab_missing.nrrd"), &v, &err) == VM_ERR_IO);
    CHECK(strstr(err.message, "cannot open") != NULL);
}

/* The slab needs memory for itself only: a volume whose floats exceed the limit still
 * gives up its header and a slab that fits. */
static void slabOfAVolumeAboveTheMemoryLimitIsRead(void) {
    const char *path = vm_test_tmp("slab_limit.nrrd");
    char hdr[256];
    snprintf(hdr, sizeof hdr, "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 100 100 100\n"
             "encoding: raw\n\n");
    size_t hl = strlen(hdr), n = 1000000;
    unsigned char *buf = calloc(1, hl + n);
    memcpy(buf, hdr, hl);
    buf[hl + n - 1] = 7;
    vm_test_write_file(path, buf, hl + n);
    free(buf);
    setenv("VOLMESH_MAX_MEMORY", "1000000", 1); /* 1 MB: the floats need 4 MB */
    vm_volume v;
    vm_error err;
    CHECK(vm_volume_read(path, &v, &err) == VM_ERR_NOMEM);
    CHECK(strstr(err.message, "memory limit") != NULL);
    CHECK_OK(vm_volume_read_info(path, &v, &err), &err);
    CHECK(v.dims[2] == 100);
    CHECK_OK(vm_volume_read_slab(path, 90, 100, &v, &err), &err);
    if (v.data) CHECK(v.data[100 * 100 * 10 - 1] == 7.0f && v.data[0] == 0.0f);
    vm_volume_free(&v);
    CHECK(vm_volume_read_slab(path, 0, 100, &v, &err) == VM_ERR_NOMEM);
    unsetenv("VOLMESH_MAX_MEMORY");
}

/* A named pipe cannot be mapped: it is read into memory, and the slab is still right (the
 * pages of a buffer are never given back, which would zero them). */
static void slabOfANamedPipeIsReadFromMemory(void) {
    make_files();
    const char *src = vm_test_tmp("slab_gz.nrrd");
    char fifo[4096];
    snprintf(fifo, sizeof fifo, "%s", vm_test_tmp("slab_fifo.nrrd"));
    FILE *fp = fopen(src, "rb");
    CHECK(fp != NULL);
    if (!fp) return;
    unsigned char *buf = malloc(1 << 16);
    size_t len = fread(buf, 1, 1 << 16, fp);
    fclose(fp);
    vm_volume whole, s;
    vm_error err;
    CHECK_OK(vm_volume_read(src, &whole, &err), &err);
    remove(fifo);
    CHECK(mkfifo(fifo, 0600) == 0);
    fflush(NULL);
    pid_t pid = fork();
    if (pid == 0) {
        FILE *w = fopen(fifo, "wb");
        if (w) {
            fwrite(buf, 1, len, w);
            fclose(w);
        }
        _exit(0);
    }
    CHECK(pid > 0);
    CHECK_OK(vm_volume_read_slab(fifo, 2, 5, &s, &err), &err);
    if (pid > 0) waitpid(pid, NULL, 0);
    if (s.data && whole.data) check_slab("slab_fifo.nrrd", &whole, &s, 2, 5);
    vm_volume_free(&s);
    vm_volume_free(&whole);
    remove(fifo);
    free(buf);
}

/* A forward reader (vm_volume_reader) gives the same planes as the whole read for every
 * storage, read forward, again from an earlier plane, and on to the end; into the caller's
 * buffer only. */
static void forwardReaderEqualsTheWholeReadInEveryFormat(void) {
    make_files();
    static const int64_t cuts[][2] = {{0, 2}, {2, 3}, {3, 6}, {1, 4}, {4, 6}, {0, 6}};
    for (size_t f = 0; f <= sizeof files / sizeof files[0]; f++) {
        int raw = f == sizeof files / sizeof files[0];
        const char *name = raw ? "slab.raw" : files[f], *path = vm_test_tmp(name);
        vm_raw_options o;
        raw_options(&o);
        vm_volume whole, info;
        vm_error err;
        CHECK_OK(raw ? vm_volume_read_raw(path, &o, &whole, &err)
                     : vm_volume_read(path, &whole, &err),
                 &err);
        vm_volume_reader *r = NULL;
        CHECK_OK(vm_volume_reader_open(path, raw ? &o : NULL, &info, &r, &err), &err);
        if (!whole.data || !r) {
            vm_volume_free(&whole);
            vm_volume_reader_close(r);
            continue;
        }
        CHECK(info.data == NULL && memcmp(info.dims, whole.dims, sizeof info.dims) == 0 &&
              memcmp(info.origin, whole.origin, sizeof info.origin) == 0);
        size_t plane = NX * NY;
        float *buf = malloc(N * sizeof(float));
        for (size_t c = 0; buf && c < sizeof cuts / sizeof cuts[0]; c++) {
            int64_t z0 = cuts[c][0], z1 = cuts[c][1];
            for (size_t i = 0; i < N; i++)
                buf[i] = -1;
            CHECK_OK(vm_volume_reader_read(r, z0, z1, buf, &err), &err);
            size_t n = plane * (size_t)(z1 - z0);
            int same = memcmp(buf, whole.data + plane * (size_t)z0, n * sizeof(float)) == 0;
            CHECK_MSG(same && (n == N || buf[n] == -1),
                      "%s: planes %lld..%lld differ from the whole read", name, (long long)z0,
                      (long long)z1 - 1);
        }
        vm_error_clear(&err);
        vm_status st = buf ? vm_volume_reader_read(r, 4, 7, buf, &err) : VM_ERR_ARG;
        CHECK_MSG(st == VM_ERR_ARG && strstr(err.message, path) &&
                      strstr(err.message, "outside"),
                  "%s: planes 4..6 of 6: '%s'", name, err.message);
        free(buf);
        vm_volume_free(&whole);
        vm_volume_free(&info);
        vm_volume_reader_close(r);
    }
    vm_volume_reader *r = NULL;
    vm_volume info;
    vm_error err;
    const char *missing = vm_test_tmp("no_such_volume.nrrd");
    vm_status st = vm_volume_reader_open(missing, NULL, &info, &r, &err);
    CHECK_MSG(st == VM_ERR_IO && r == NULL &&
                  strncmp(err.message, missing, strlen(missing)) == 0,
              "missing file: %d '%s'", (int)st, err.message);
}

/* The reader goes on where the previous slab ended: after planes 0..1 the start of the
 * data is damaged (gzip NRRD, ASCII NRRD); reading on from plane 2 still works (nothing before
 * it is read again), while a slab read or the reader going back, which start from the
 * beginning, fail. */
static void forwardReaderGoesOnWhereTheLastSlabEnded(void) {
    make_files();
    static const char *const names[] = {"slab_gz.nrrd", "slab_ascii.nrrd"};
    for (int f = 0; f < 2; f++) {
        const char *path = vm_test_tmp(names[f]);
        vm_volume whole;
        vm_error err;
        CHECK_OK(vm_volume_read(path, &whole, &err), &err);
        vm_volume_reader *r = NULL;
        CHECK_OK(vm_volume_reader_open(path, NULL, NULL, &r, &err), &err);
        float *buf = malloc(N * sizeof(float));
        FILE *fp = fopen(path, "rb");
        unsigned char *bytes = malloc(64 * N + 4096);
        size_t len = fp && bytes ? fread(bytes, 1, 64 * N + 4096, fp) : 0;
        if (fp) fclose(fp);
        unsigned char *data = len ? (unsigned char *)strstr((char *)bytes, "\n\n") : NULL;
        if (!whole.data || !r || !buf || !data) {
            CHECK(0);
        } else {
            size_t plane = NX * NY;
            CHECK_OK(vm_volume_reader_read(r, 0, 2, buf, &err), &err);
            /* the gzip magic; in the text, the space after the first value, which merges
             * two values into one word (all the later ones shift by one) */
            if (f == 0)
                memcpy(data + 2, "XX", 2);
            else
                *(unsigned char *)strchr((char *)data + 2, ' ') = 'X';
            CHECK(vm_test_write_file(path, bytes, len) == 0);
            CHECK_OK(vm_volume_reader_read(r, 2, 6, buf, &err), &err);
            CHECK_MSG(memcmp(buf, whole.data + 2 * plane, 4 * plane * sizeof(float)) == 0,
                      "%s: planes 2..5 read on differ", names[f]);
            vm_volume s;
            vm_error_clear(&err);
            vm_status st = vm_volume_read_slab(path, 2, 6, &s, &err);
            CHECK_MSG(st == VM_ERR_FORMAT && strstr(err.message, path),
                      "%s: the damaged file read as a slab: %d '%s'", names[f], (int)st,
                      err.message);
            vm_volume_free(&s);
            st = vm_volume_reader_read(r, 0, 2, buf, &err);
            CHECK_MSG(st == VM_ERR_FORMAT, "%s: going back read the damaged start: %d",
                      names[f], (int)st);
        }
        free(bytes);
        free(buf);
        vm_volume_free(&whole);
        vm_volume_reader_close(r);
    }
}

int main(void) {
    static const vm_test_case cases[] = {
        {"slabsConcatenatedEqualTheWholeReadInEveryFormat",
         slabsConcatenatedEqualTheWholeReadInEveryFormat},
        {"slabsOfAThreadedConversionEqualTheWholeRead",
         slabsOfAThreadedConversionEqualTheWholeRead},
        {"slabReadsRefuseBadRangesTruncatedDataAndLyingHeaders",
         slabReadsRefuseBadRangesTruncatedDataAndLyingHeaders},
        {"slabOfAVolumeAboveTheMemoryLimitIsRead", slabOfAVolumeAboveTheMemoryLimitIsRead},
        {"slabOfANamedPipeIsReadFromMemory", slabOfANamedPipeIsReadFromMemory},
        {"forwardReaderEqualsTheWholeReadInEveryFormat",
         forwardReaderEqualsTheWholeReadInEveryFormat},
        {"forwardReaderGoesOnWhereTheLastSlabEnded", forwardReaderGoesOnWhereTheLastSlabEnded},
    };
    return vm_test_run(cases, sizeof cases / sizeof cases[0]);
}
