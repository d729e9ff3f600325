/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_tiff.c — the TIFF reader against files libtiff writes here: an ImageJ stack,
 * a folder of slices in natural order, a tiled float zlib stack with OME-XML, every sample
 * type, slabs, and truncated or lying files refused in one line (exit 2 from the CLI).
 * Without libtiff in the build, a TIFF input is refused in one line naming libtiff. */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <string.h>
#include "test.h"
#ifdef VM_HAVE_TIFF
#include <tiffio.h>
#endif

/* Exit 2 from `volmesh info PATH`, one line naming the path and containing phrase. */
static void expect_cli_refusal(const char *path, const char *phrase) {
    char args[4400], *out = NULL;
    snprintf(args, sizeof args, "info '%s'", path);
    int rc = vm_test_cli(args, &out);
    const char *o = out ? out : "";
    CHECK_MSG(rc == 2, "info %s exited %d: %s", path, rc, o);
    CHECK_MSG(strstr(o, path) && strstr(o, phrase), "info %s printed '%s', without '%s'", path,
              o, phrase);
    CHECK_MSG(strchr(o, '\n') == o + strlen(o) - 1, "info %s: not one line: %s", path, o);
    free(out);
}

#ifndef VM_HAVE_TIFF

static void tiffIsRefusedInOneLineWithoutLibtiff(void) {
    const char *path = vm_test_tmp("tiff_absent.tif");
    CHECK(vm_test_write_file(path, "II*\0\10\0\0\0", 8) == 0);
    vm_volume v;
    vm_error err;
    CHECK(vm_volume_read(path, &v, &err) == VM_ERR_UNSUPPORTED &&
          strstr(err.message, "libtiff-dev"));
    CHECK(!vm_tiff_available());
    expect_cli_refusal(path, "libtiff");
}

TEST_MAIN(T(tiffIsRefusedInOneLineWithoutLibtiff))

#else

/* Value of voxel (i, j, k) of the test stacks (distinct, exact in every type used). */
static double value(int i, int j, int k) { return i + 10 * j + 100 * k; }

/* What one page is written as. */
typedef struct page_spec {
    int w, h;
    int bits, format; /* SAMPLEFORMAT_* */
    int compression;  /* COMPRESSION_* */
    int tile;         /* 0: strips of rows_per_strip rows; else tiles of tile x tile */
    int rows_per_strip;
    double scale, offset; /* sample = value * scale + offset */
    const char *description; /* first page only, NULL: none */
    float xres, yres;        /* 0: none */
} page_spec;

/* The sample of (i, j, k) stored in buf at index n, in the type of p. */
static void put_sample(const page_spec *p, unsigned char *buf, size_t n, double x) {
    if (p->format == SAMPLEFORMAT_IEEEFP && p->bits == 32) ((float *)buf)[n] = (float)x;
    else if (p->format == SAMPLEFORMAT_IEEEFP) ((double *)buf)[n] = x;
    else if (p->bits == 8 && p->format == SAMPLEFORMAT_INT) ((int8_t *)buf)[n] = (int8_t)x;
    else if (p->bits == 8) buf[n] = (uint8_t)x;
    else if (p->bits == 16 && p->format == SAMPLEFORMAT_INT) ((int16_t *)buf)[n] = (int16_t)x;
    else if (p->bits == 16) ((uint16_t *)buf)[n] = (uint16_t)x;
    else if (p->format == SAMPLEFORMAT_INT) ((int32_t *)buf)[n] = (int32_t)x;
    else ((uint32_t *)buf)[n] = (uint32_t)x;
}

/* x as the type of p stores it (cast like put_sample), back as a double. */
static double stored(const page_spec *p, double x) {
    union {
        unsigned char b[8];
        double d;
    } u;
    put_sample(p, u.b, 0, x);
    if (p->format == SAMPLEFORMAT_IEEEFP) return p->bits == 32 ? *(float *)u.b : u.d;
    int sgn = p->format == SAMPLEFORMAT_INT;
    if (p->bits == 8) return sgn ? (double)*(int8_t *)u.b : (double)u.b[0];
    if (p->bits == 16) return sgn ? (double)*(int16_t *)u.b : (double)*(uint16_t *)u.b;
    return sgn ? (double)*(int32_t *)u.b : (double)*(uint32_t *)u.b;
}

/* Writes the current page of t: plane k of the test values. */
static void write_page(TIFF *t, const page_spec *p, int k, int first) {
    TIFFSetField(t, TIFFTAG_IMAGEWIDTH, (uint32_t)p->w);
    TIFFSetField(t, TIFFTAG_IMAGELENGTH, (uint32_t)p->h);
    TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, (uint16_t)p->bits);
    TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, (uint16_t)1);
    TIFFSetField(t, TIFFTAG_SAMPLEFORMAT, (uint16_t)p->format);
    TIFFSetField(t, TIFFTAG_PHOTOMETRIC, (uint16_t)PHOTOMETRIC_MINISBLACK);
    TIFFSetField(t, TIFFTAG_PLANARCONFIG, (uint16_t)PLANARCONFIG_CONTIG);
    TIFFSetField(t, TIFFTAG_COMPRESSION, (uint16_t)p->compression);
    if (first && p->description) TIFFSetField(t, TIFFTAG_IMAGEDESCRIPTION, p->description);
    if (p->xres > 0) {
        TIFFSetField(t, TIFFTAG_XRESOLUTION, p->xres);
        TIFFSetField(t, TIFFTAG_YRESOLUTION, p->yres);
        TIFFSetField(t, TIFFTAG_RESOLUTIONUNIT, (uint16_t)RESUNIT_NONE);
    }
    size_t ts = (size_t)p->bits / 8;
    if (p->tile) {
        TIFFSetField(t, TIFFTAG_TILEWIDTH, (uint32_t)p->tile);
        TIFFSetField(t, TIFFTAG_TILELENGTH, (uint32_t)p->tile);
        unsigned char *buf = calloc((size_t)p->tile * p->tile, ts);
        for (int y = 0; y < p->h; y += p->tile)
            for (int x = 0; x < p->w; x += p->tile) {
                memset(buf, 0, (size_t)p->tile * p->tile * ts);
                for (int r = 0; r < p->tile && y + r < p->h; r++)
                    for (int c = 0; c < p->tile && x + c < p->w; c++)
                        put_sample(p, buf, (size_t)r * p->tile + c,
                                   value(x + c, y + r, k) * p->scale + p->offset);
                CHECK(TIFFWriteTile(t, buf, (uint32_t)x, (uint32_t)y, 0, 0) > 0);
            }
        free(buf);
    } else {
        TIFFSetField(t, TIFFTAG_ROWSPERSTRIP, (uint32_t)p->rows_per_strip);
        unsigned char *row = malloc((size_t)p->w * ts);
        for (int j = 0; j < p->h; j++) {
            for (int i = 0; i < p->w; i++) put_sample(p, row, (size_t)i, value(i, j, k) * p->scale + p->offset);
            CHECK(TIFFWriteScanline(t, row, (uint32_t)j, 0) == 1);
        }
        free(row);
    }
    CHECK(TIFFWriteDirectory(t) == 1);
}

/* Writes planes k0 .. k0+n-1 as the pages of path. */
static void write_tiff(const char *path, const page_spec *p, int k0, int n) {
    TIFF *t = TIFFOpen(path, "w");
    CHECK(t != NULL);
    if (!t) return;
    for (int k = 0; k < n; k++) write_page(t, p, k0 + k, k == 0);
    TIFFClose(t);
}

/* v holds the test values of dims w x h x n scaled as p stores them, spacing sp. */
static void expect_stack(const vm_volume *v, const page_spec *p, int n, const double sp[3],
                         const char *what) {
    CHECK_MSG(v->dims[0] == p->w && v->dims[1] == p->h && v->dims[2] == n,
              "%s: dims %lld %lld %lld", what, (long long)v->dims[0], (long long)v->dims[1],
              (long long)v->dims[2]);
    if (v->dims[0] != p->w || v->dims[1] != p->h || v->dims[2] != n || !v->data) return;
    size_t bad = 0;
    for (int k = 0; k < n; k++)
        for (int j = 0; j < p->h; j++)
            for (int i = 0; i < p->w; i++) {
                float want = (float)stored(p, value(i, j, k) * p->scale + p->offset);
                float got = v->data[i + (size_t)p->w * (j + (size_t)p->h * k)];
                if (got != want && bad++ == 0)
                    CHECK_MSG(0, "%s: voxel (%d, %d, %d) is %.9g, expected %.9g", what, i, j, k,
                              got, want);
            }
    for (int a = 0; a < 3; a++) CHECK_NEAR(v->spacing[a], sp[a], 1e-6 * sp[a]);
    CHECK(v->origin[0] == 0 && v->origin[2] == 0 && v->direction[2][2] == 1.0);
    CHECK(strcmp(v->format, "tiff") == 0);
}

static const char IMAGEJ_DESC[] =
    "ImageJ=1.54f\nimages=5\nslices=5\nunit=micron\nspacing=2.5\nloop=false\n";

static void tiffReadsAnImageJStackWithItsSpacing(void) {
    page_spec p = {9, 7, 16, SAMPLEFORMAT_UINT, COMPRESSION_NONE, 0, 2, 1.0, 3.0, IMAGEJ_DESC,
                   2.0f, 4.0f};
    const char *path = vm_test_tmp("tiff_imagej.tif");
    write_tiff(path, &p, 0, 5);
    vm_volume v;
    vm_error err;
    const double sp[3] = {0.5, 0.25, 2.5};
    CHECK_OK(vm_volume_read(path, &v, &err), &err);
    expect_stack(&v, &p, 5, sp, "ImageJ stack");
    CHECK(v.type == VM_SCALAR_UINT16);
    /* slabs and the header alone agree with the whole read */
    vm_volume slab, info;
    CHECK_OK(vm_volume_read_slab(path, 2, 4, &slab, &err), &err);
    CHECK(slab.dims[2] == 2 && memcmp(slab.data, v.data + 2 * 63, 2 * 63 * sizeof(float)) == 0);
    CHECK_NEAR(slab.origin[2], 5.0, 1e-12);
    CHECK_OK(vm_volume_read_info(path, &info, &err), &err);
    CHECK(info.dims[2] == 5 && !info.data && info.spacing[2] == 2.5);
    vm_volume_free(&slab);
    vm_volume_free(&info);
    vm_volume_free(&v);
    /* the CLI shows it, and --spacing replaces it */
    char args[4400], *out = NULL;
    snprintf(args, sizeof args, "info '%s' --json", path);
    CHECK(vm_test_cli(args, &out) == 0);
    CHECK_MSG(out && strstr(out, "\"format\": \"tiff\", \"dims\": [9, 7, 5], \"type\": \"uint16\"") &&
                  strstr(out, "\"spacing\": [0.5, 0.25, 2.5]"),
              "%s", out ? out : "");
    free(out);
    snprintf(args, sizeof args, "info '%s' --json --spacing 1,2,3", path);
    CHECK(vm_test_cli(args, &out) == 0);
    CHECK_MSG(out && strstr(out, "\"spacing\": [1, 2, 3]"), "%s", out ? out : "");
    free(out);
}

static void tiffReadsAFolderOfSlicesInNaturalOrder(void) {
    const char *dir = vm_test_tmp("tiff_folder");
    char cmd[4200], path[4400];
    snprintf(cmd, sizeof cmd, "rm -rf '%s' && mkdir -p '%s/sub'", dir, dir);
    CHECK(system(cmd) == 0);
    page_spec p = {6, 5, 16, SAMPLEFORMAT_INT, COMPRESSION_LZW, 0, 3, -1.0, 100.0, NULL, 0, 0};
    /* slice k in "slice<k+1>.tif": natural order puts slice10 after slice9 */
    for (int k = 0; k < 11; k++) {
        snprintf(path, sizeof path, "%s/slice%d.%s", dir, k + 1, k == 3 ? "TIFF" : "tif");
        write_tiff(path, &p, k, 1);
    }
    snprintf(path, sizeof path, "%s/notes.txt", dir);
    CHECK(vm_test_write_file(path, "not a slice\n", 12) == 0);
    snprintf(path, sizeof path, "%s/sub/other.tif", dir); /* not a slice: a subfolder */
    write_tiff(path, &p, 50, 1);
    vm_volume v;
    vm_error err;
    const double sp[3] = {1, 1, 1};
    CHECK_OK(vm_volume_read(dir, &v, &err), &err);
    expect_stack(&v, &p, 11, sp, "folder of slices");
    CHECK(v.type == VM_SCALAR_INT16);
    vm_volume_free(&v);
    /* a slice of another size is named */
    page_spec q = p;
    q.w = 7;
    snprintf(path, sizeof path, "%s/slice12.tif", dir);
    write_tiff(path, &q, 11, 1);
    CHECK(vm_volume_read(dir, &v, &err) == VM_ERR_FORMAT && strstr(err.message, "slice12.tif") &&
          strstr(err.message, "7x5 int16, but the first page of"));
    expect_cli_refusal(dir, "slice12.tif: page 1 is 7x5");
}

static const char OME_DESC[] =
    "<?xml version=\"1.0\" encoding=\"UTF-8\"?><OME xmlns=\"http://www.openmicroscopy.org/"
    "Schemas/OME/2016-06\"><Image ID=\"Image:0\"><Pixels ID=\"Pixels:0\" DimensionOrder="
    "\"XYZCT\" Type=\"float\" SizeX=\"20\" SizeY=\"18\" SizeZ=\"4\" SizeC=\"1\" SizeT=\"1\" "
    "PhysicalSizeX=\"0.3\" PhysicalSizeY=\"0.35\" PhysicalSizeZ=\"1.75\"><TiffData/></Pixels>"
    "</Image></OME>";

static void tiffReadsATiledFloatZlibStackWithOmeSpacing(void) {
    page_spec p = {20, 18, 32, SAMPLEFORMAT_IEEEFP, COMPRESSION_ADOBE_DEFLATE, 16, 0, 0.125,
                   -7.5, OME_DESC, 0, 0};
    const char *path = vm_test_tmp("tiff_float.ome.tiff");
    write_tiff(path, &p, 0, 4);
    vm_volume v;
    vm_error err;
    const double sp[3] = {0.3, 0.35, 1.75};
    CHECK_OK(vm_volume_read(path, &v, &err), &err);
    expect_stack(&v, &p, 4, sp, "float zlib tiles");
    CHECK(v.type == VM_SCALAR_FLOAT32);
    vm_volume_free(&v);
    /* zlib in strips, read by a reader slab after slab */
    page_spec s = p;
    s.tile = 0, s.rows_per_strip = 5, s.description = NULL;
    path = vm_test_tmp("tiff_float_strips.tif");
    write_tiff(path, &s, 0, 4);
    vm_volume_reader *r = NULL;
    float planes[20 * 18 * 4];
    CHECK_OK(vm_volume_reader_open(path, NULL, NULL, &r, &err), &err);
    CHECK_OK(vm_volume_reader_read(r, 0, 3, planes, &err), &err);
    CHECK_OK(vm_volume_reader_read(r, 3, 4, planes + 3 * 360, &err), &err);
    vm_volume_reader_close(r);
    CHECK(planes[5 + 20 * 7 + 360 * 3] == (float)(value(5, 7, 3) * 0.125 - 7.5));
}

static void tiffReadsEverySampleType(void) {
    static const struct {
        int bits, format;
        vm_scalar_type type;
        double scale, offset;
        int compression;
    } cases[] = {
        {8, SAMPLEFORMAT_UINT, VM_SCALAR_UINT8, 0.5, 0, COMPRESSION_NONE},
        {8, SAMPLEFORMAT_INT, VM_SCALAR_INT8, -0.25, 10, COMPRESSION_PACKBITS},
        {16, SAMPLEFORMAT_UINT, VM_SCALAR_UINT16, 100, 7, COMPRESSION_LZW},
        {32, SAMPLEFORMAT_UINT, VM_SCALAR_UINT32, 1000, 1, COMPRESSION_ADOBE_DEFLATE},
        {32, SAMPLEFORMAT_INT, VM_SCALAR_INT32, -1000, -5, COMPRESSION_NONE},
        {64, SAMPLEFORMAT_IEEEFP, VM_SCALAR_FLOAT64, 0.001, 0.5, COMPRESSION_ADOBE_DEFLATE},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        page_spec p = {5, 4, cases[c].bits, cases[c].format, cases[c].compression, 0, 1,
                       cases[c].scale, cases[c].offset, NULL, 0, 0};
        char name[64];
        snprintf(name, sizeof name, "tiff_type_%zu.tif", c);
        const char *path = vm_test_tmp(name);
        write_tiff(path, &p, 0, 3);
        vm_volume v;
        vm_error err;
        const double sp[3] = {1, 1, 1};
        CHECK_OK(vm_volume_read(path, &v, &err), &err);
        expect_stack(&v, &p, 3, sp, vm_scalar_type_name(cases[c].type));
        CHECK(v.type == cases[c].type);
        vm_volume_free(&v);
    }
}

/* Writes bytes [0, keep) of src to dst. */
static void truncate_copy(const char *src, const char *dst, double fraction) {
    FILE *f = fopen(src, "rb");
    CHECK(f != NULL);
    if (!f) return;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *buf = malloc((size_t)n);
    CHECK(fread(buf, 1, (size_t)n, f) == (size_t)n);
    fclose(f);
    CHECK(vm_test_write_file(dst, buf, (size_t)((double)n * fraction)) == 0);
    free(buf);
}

static void tiffRefusesTruncatedAndLyingFilesInOneLine(void) {
    page_spec p = {40, 30, 32, SAMPLEFORMAT_IEEEFP, COMPRESSION_ADOBE_DEFLATE, 0, 8, 0.5, 0,
                   NULL, 0, 0};
    const char *good = vm_test_tmp("tiff_good.tif");
    write_tiff(good, &p, 0, 3);
    /* cut: the last page directory, or strips, are gone */
    static const double cuts[] = {0.97, 0.6, 0.3, 0.05};
    for (size_t c = 0; c < sizeof cuts / sizeof cuts[0]; c++) {
        char name[64];
        snprintf(name, sizeof name, "tiff_cut_%zu.tif", c);
        const char *path = vm_test_tmp(name);
        truncate_copy(good, path, cuts[c]);
        vm_volume v;
        vm_error err;
        vm_status st = vm_volume_read(path, &v, &err);
        CHECK_MSG(st != VM_OK && strstr(err.message, path) && !strchr(err.message, '\n'),
                  "cut %g: %d %s", cuts[c], (int)st, err.message);
        if (st == VM_OK) vm_volume_free(&v);
        expect_cli_refusal(path, "");
    }
    /* directories intact, the first strips' zlib data garbled (libtiff writes each page's
     * data before its directory) */
    FILE *f = fopen(good, "rb");
    unsigned char head[4096];
    size_t got = f ? fread(head, 1, sizeof head, f) : 0;
    if (f) fclose(f);
    CHECK(got > 1000);
    memset(head + 64, 0x5a, 600);
    FILE *g = fopen(good, "rb");
    const char *garbled = vm_test_tmp("tiff_garbled.tif");
    FILE *h = fopen(garbled, "wb");
    unsigned char chunk[4096];
    size_t m, total = 0;
    while (g && h && (m = fread(chunk, 1, sizeof chunk, g)) > 0) {
        fwrite(total == 0 ? head : chunk, 1, m, h);
        total += m;
    }
    if (g) fclose(g);
    if (h) fclose(h);
    expect_cli_refusal(garbled, "page 1: strip 0 is truncated or corrupt (libtiff: ");
    /* not TIFF at all, empty, and colour */
    const char *text = vm_test_tmp("tiff_text.tif");
    CHECK(vm_test_write_file(text, "hello, not a TIFF\n", 18) == 0);
    expect_cli_refusal(text, "not a readable TIFF file");
    expect_cli_refusal(vm_test_tmp("tiff_absent.tif"), "cannot open (No such file");
    const char *empty = vm_test_tmp("tiff_empty.tif");
    CHECK(vm_test_write_file(empty, "", 0) == 0);
    expect_cli_refusal(empty, "not a readable TIFF file");
    const char *rgb = vm_test_tmp("tiff_rgb.tif");
    TIFF *t = TIFFOpen(rgb, "w");
    unsigned char row[12] = {0};
    TIFFSetField(t, TIFFTAG_IMAGEWIDTH, 4u);
    TIFFSetField(t, TIFFTAG_IMAGELENGTH, 2u);
    TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, 8);
    TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, 3);
    TIFFSetField(t, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_RGB);
    TIFFSetField(t, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
    TIFFWriteScanline(t, row, 0, 0);
    TIFFWriteScanline(t, row, 1, 0);
    TIFFClose(t);
    expect_cli_refusal(rgb, "3 samples per pixel");
    /* metadata that lies: a zero spacing, a hyperstack, an OME plane count */
    page_spec q = {4, 3, 8, SAMPLEFORMAT_UINT, COMPRESSION_NONE, 0, 3, 1, 0,
                   "ImageJ=1.54f\nimages=2\nslices=2\nspacing=0\n", 1.0f, 1.0f};
    const char *path = vm_test_tmp("tiff_zero_spacing.tif");
    write_tiff(path, &q, 0, 2);
    expect_cli_refusal(path, "ImageJ spacing= gives the spacing 0");
    q.description = "ImageJ=1.54f\nimages=4\nchannels=2\nslices=2\nhyperstack=true\n";
    path = vm_test_tmp("tiff_channels.tif");
    write_tiff(path, &q, 0, 4);
    expect_cli_refusal(path, "ImageJ hyperstack of 2 channels");
    q.description = "<OME><Image><Pixels SizeZ=\"9\" SizeC=\"1\" SizeT=\"1\"/></Image></OME>";
    path = vm_test_tmp("tiff_ome_lie.tif");
    write_tiff(path, &q, 0, 2);
    expect_cli_refusal(path, "OME-XML SizeZ=9 but the stack holds 2 pages");
    /* a folder with no slice is DICOM's to refuse; a folder of one bad slice is named */
    const char *dir = vm_test_tmp("tiff_bad_folder");
    char cmd[4200], slice[4400];
    snprintf(cmd, sizeof cmd, "rm -rf '%s' && mkdir -p '%s'", dir, dir);
    CHECK(system(cmd) == 0);
    snprintf(slice, sizeof slice, "%s/a.tif", dir);
    CHECK(vm_test_write_file(slice, "II*\0\377\377\0\0", 8) == 0);
    expect_cli_refusal(dir, "a.tif: not a readable TIFF file");
}

TEST_MAIN(T(tiffReadsAnImageJStackWithItsSpacing), T(tiffReadsAFolderOfSlicesInNaturalOrder),
          T(tiffReadsATiledFloatZlibStackWithOmeSpacing), T(tiffReadsEverySampleType),
          T(tiffRefusesTruncatedAndLyingFilesInOneLine))

#endif
