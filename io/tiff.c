/* SPDX-License-Identifier: BSD-3-Clause */
/* io/tiff.c — TIFF stacks read with libtiff: a multi-page file, or a folder of slices in
 * natural name order; one channel of 8/16/32-bit integers or 32/64-bit floats, in strips or
 * tiles, any compression libtiff decodes. Spacing from ImageJ's ImageDescription (spacing=,
 * unit=, with XResolution/YResolution) or OME-XML (Pixels PhysicalSizeX/Y/Z). Follows TIFF
 * 6.0 (sections 2, 8, 15, 19: pages, strips, tiles, SampleFormat), the ImageJ description
 * written by ij.io.TiffEncoder and the OME-TIFF / OME-XML Pixels element. */
#define _POSIX_C_SOURCE 200809L
#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include "../core/core.h"
#include "io_util.h"
#include "volmesh/io.h"
#ifdef VM_HAVE_TIFF
#include <tiffio.h>
#endif

/* 1 when name ends in .tif or .tiff (any case). */
static int tiff_name(const char *name) {
    return vm__ends_with(name, ".tif") || vm__ends_with(name, ".tiff");
}

/* 1 when path is a folder holding at least one .tif/.tiff file at its top level. */
int vm__tiff_folder(const char *path) {
    DIR *d = opendir(path);
    if (!d) return 0;
    int found = 0;
    struct dirent *e;
    while (!found && (e = readdir(d)) != NULL) found = e->d_name[0] != '.' && tiff_name(e->d_name);
    closedir(d);
    return found;
}

#ifndef VM_HAVE_TIFF

int vm_tiff_available(void) { return 0; }

vm_status vm__read_tiff(const char *path, const vm__slab *rq, vm_volume *v, vm_error *err) {
    (void)rq;
    memset(v, 0, sizeof *v);
    return vm_error_set(err, VM_ERR_UNSUPPORTED,
                        "%s: TIFF is not read by this build of volmesh (libtiff was not found "
                        "when it was built; Debian: libtiff-dev, then configure again)",
                        path);
}

#else

int vm_tiff_available(void) { return 1; }

/* Natural order of names: runs of digits compare as numbers ("s2" < "s10"). */
static int natural_cmp(const char *a, const char *b) {
    while (*a && *b) {
        if (isdigit((unsigned char)*a) && isdigit((unsigned char)*b)) {
            while (*a == '0') a++;
            while (*b == '0') b++;
            size_t la = strspn(a, "0123456789"), lb = strspn(b, "0123456789");
            if (la != lb) return la < lb ? -1 : 1;
            int c = strncmp(a, b, la);
            if (c) return c;
            a += la, b += lb;
        } else {
            if (*a != *b) return (unsigned char)*a < (unsigned char)*b ? -1 : 1;
            a++, b++;
        }
    }
    return *a ? 1 : *b ? -1 : 0;
}

static int natural_qsort(const void *x, const void *y) {
    int c = natural_cmp(*(char *const *)x, *(char *const *)y);
    return c ? c : strcmp(*(char *const *)x, *(char *const *)y);
}

/* The first libtiff error of one open file, for the one-line message (warnings dropped). */
typedef struct tiff_msg {
    char text[200];
    int set;
} tiff_msg;

static int on_error(TIFF *t, void *user, const char *module, const char *fmt, va_list ap) {
    (void)t, (void)module;
    tiff_msg *m = user;
    if (!m->set) {
        vsnprintf(m->text, sizeof m->text, fmt, ap);
        for (char *c = m->text; *c; c++)
            if (*c == '\n' || *c == '\r') *c = ' ';
        m->set = 1;
    }
    return 1; /* handled: nothing on stderr */
}

static int on_warning(TIFF *t, void *user, const char *module, const char *fmt, va_list ap) {
    (void)t, (void)user, (void)module, (void)fmt, (void)ap;
    return 1;
}

/* One open file of the stack. */
typedef struct tiff_open {
    TIFF *t;
    tiff_msg msg;
    size_t index; /* into the file list; (size_t)-1 when none is open */
} tiff_open;

/* What every page must share with the first. */
typedef struct page_fmt {
    uint32_t w, h;
    uint16_t bits, format;
    vm_scalar_type type;
} page_fmt;

/* The stack: its files (one, or a folder's slices) and pages in z order. */
typedef struct tiff_stack {
    char **files;   /* owned */
    size_t nfiles;
    size_t *page_file; /* file of each page */
    tdir_t *page_dir;  /* directory of each page in its file */
    int64_t npages;
    page_fmt fmt;
    double spacing[3];
} tiff_stack;

static void stack_free(tiff_stack *s) {
    for (size_t i = 0; i < s->nfiles; i++) free(s->files[i]);
    free(s->files);
    free(s->page_file);
    free(s->page_dir);
    memset(s, 0, sizeof *s);
}

static void close_open(tiff_open *o) {
    if (o->t) TIFFClose(o->t);
    o->t = NULL;
    o->index = (size_t)-1;
}

/* Opens file i of s into o (kept when it is already open). */
static vm_status open_file(const tiff_stack *s, size_t i, tiff_open *o, vm_error *err) {
    if (o->t && o->index == i) return VM_OK;
    close_open(o);
    memset(&o->msg, 0, sizeof o->msg);
    TIFFOpenOptions *opts = TIFFOpenOptionsAlloc();
    if (!opts) return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", s->files[i]);
    TIFFOpenOptionsSetErrorHandlerExtR(opts, on_error, &o->msg);
    TIFFOpenOptionsSetWarningHandlerExtR(opts, on_warning, NULL);
    size_t lim = vm__memory_limit();
    TIFFOpenOptionsSetMaxSingleMemAlloc(opts, (tmsize_t)(lim > (size_t)INT64_MAX / 2
                                                             ? (size_t)INT64_MAX / 2
                                                             : lim));
    o->t = TIFFOpenExt(s->files[i], "r", opts);
    TIFFOpenOptionsFree(opts);
    if (!o->t)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: not a readable TIFF file (libtiff: %s)",
                            s->files[i], o->msg.set ? o->msg.text : "cannot open");
    o->index = i;
    return VM_OK;
}

/* The libtiff message of o, or a default. */
static const char *why(const tiff_open *o, const char *dflt) {
    return o->msg.set ? o->msg.text : dflt;
}

/* The format of the current page of o ([out] f), refused unless one channel of a sample
 * type volmesh reads. */
static vm_status page_format(const char *file, tdir_t dir, tiff_open *o, page_fmt *f,
                             vm_error *err) {
    TIFF *t = o->t;
    uint32_t w = 0, h = 0;
    uint16_t bits = 1, spp = 1, fmt = SAMPLEFORMAT_UINT;
    if (!TIFFGetField(t, TIFFTAG_IMAGEWIDTH, &w) || !TIFFGetField(t, TIFFTAG_IMAGELENGTH, &h) ||
        w == 0 || h == 0)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: page %u has no image size", file,
                            (unsigned)dir + 1);
    TIFFGetFieldDefaulted(t, TIFFTAG_BITSPERSAMPLE, &bits);
    TIFFGetFieldDefaulted(t, TIFFTAG_SAMPLESPERPIXEL, &spp);
    TIFFGetFieldDefaulted(t, TIFFTAG_SAMPLEFORMAT, &fmt);
    if (spp != 1)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: page %u has %u samples per pixel "
                            "(colour or channels); only one-channel images are read", file,
                            (unsigned)dir + 1, (unsigned)spp);
    int sgn = fmt == SAMPLEFORMAT_INT, flt = fmt == SAMPLEFORMAT_IEEEFP;
    if (fmt != SAMPLEFORMAT_UINT && fmt != SAMPLEFORMAT_INT && fmt != SAMPLEFORMAT_IEEEFP &&
        fmt != SAMPLEFORMAT_VOID)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: page %u has SampleFormat %u (complex "
                            "samples are not read)", file, (unsigned)dir + 1, (unsigned)fmt);
    vm_scalar_type type;
    if (flt && bits == 32)
        type = VM_SCALAR_FLOAT32;
    else if (flt && bits == 64)
        type = VM_SCALAR_FLOAT64;
    else if (!flt && bits == 8)
        type = sgn ? VM_SCALAR_INT8 : VM_SCALAR_UINT8;
    else if (!flt && bits == 16)
        type = sgn ? VM_SCALAR_INT16 : VM_SCALAR_UINT16;
    else if (!flt && bits == 32)
        type = sgn ? VM_SCALAR_INT32 : VM_SCALAR_UINT32;
    else
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: page %u has %u-bit %s samples; read "
                            "are 8, 16 and 32-bit integers and 32 and 64-bit floats", file,
                            (unsigned)dir + 1, (unsigned)bits, flt ? "float" : "integer");
    f->w = w, f->h = h, f->bits = bits, f->format = fmt, f->type = type;
    return VM_OK;
}

/* The value of key (a line "key=value") in an ImageJ description, or NULL. */
static const char *imagej_value(const char *desc, const char *key, char *buf, size_t cap) {
    size_t kl = strlen(key);
    for (const char *line = desc; line && *line; line = strchr(line, '\n'), line += !!line) {
        if (strncmp(line, key, kl) == 0 && line[kl] == '=') {
            size_t n = strcspn(line + kl + 1, "\r\n");
            if (n >= cap) n = cap - 1;
            memcpy(buf, line + kl + 1, n);
            buf[n] = 0;
            return buf;
        }
    }
    return NULL;
}

/* The number value of attribute name="..." inside the element text el (up to its '>'), or
 * NAN when absent. [out] *bad 1 when present but not a number. */
static double xml_number(const char *el, const char *name, int *bad) {
    const char *end = strchr(el, '>');
    size_t nl = strlen(name);
    for (const char *p = el; (p = strstr(p, name)) != NULL && (!end || p < end); p += nl) {
        if (p[-1] != ' ' && p[-1] != '\t' && p[-1] != '\n' && p[-1] != '\r') continue;
        const char *q = p + nl;
        while (*q == ' ') q++;
        if (*q != '=') continue;
        q++;
        while (*q == ' ') q++;
        if (*q != '"' && *q != '\'') continue;
        char *stop;
        double v = strtod(q + 1, &stop);
        if (stop == q + 1 || *stop != q[0]) *bad = 1;
        return v;
    }
    return NAN;
}

/* One spacing from the file, checked against the limits every reader keeps. */
static vm_status take_spacing(const char *file, const char *what, double s, double *dst,
                              vm_error *err) {
    if (!vm__spacing_in_range(s))
        return vm_error_set(err, VM_ERR_FORMAT, "%s: %s gives the spacing %g (a spacing is a "
                            "number from %g to %g)", file, what, s, VM_SPACING_MIN,
                            VM_SPACING_MAX);
    *dst = s;
    return VM_OK;
}

/* Spacing and the layout checks of ImageJ's description (one channel, one time point or
 * one z position). */
static vm_status imagej_meta(const char *file, TIFF *t, const char *desc, double sp[3],
                             vm_error *err) {
    char buf[64];
    long ch = imagej_value(desc, "channels", buf, sizeof buf) ? strtol(buf, NULL, 10) : 1;
    long sl = imagej_value(desc, "slices", buf, sizeof buf) ? strtol(buf, NULL, 10) : 1;
    long fr = imagej_value(desc, "frames", buf, sizeof buf) ? strtol(buf, NULL, 10) : 1;
    if (ch > 1 || (fr > 1 && sl > 1))
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: an ImageJ hyperstack of %ld channels, "
                            "%ld slices and %ld frames; only one channel at one time point is "
                            "read", file, ch, sl, fr);
    float xr = 0, yr = 0;
    vm_status st = VM_OK;
    if (TIFFGetField(t, TIFFTAG_XRESOLUTION, &xr) && xr != 0.0f)
        st = take_spacing(file, "ImageJ XResolution", 1.0 / (double)xr, &sp[0], err);
    if (!st && TIFFGetField(t, TIFFTAG_YRESOLUTION, &yr) && yr != 0.0f)
        st = take_spacing(file, "ImageJ YResolution", 1.0 / (double)yr, &sp[1], err);
    if (!st && imagej_value(desc, "spacing", buf, sizeof buf)) {
        char *stop;
        double z = strtod(buf, &stop);
        st = take_spacing(file, "ImageJ spacing=", stop == buf ? NAN : z, &sp[2], err);
    }
    return st;
}

/* Spacing from the OME-XML Pixels element; one channel and one time point, and as many
 * planes as the stack holds. */
static vm_status ome_meta(const char *file, const char *desc, int64_t pages, double sp[3],
                          vm_error *err) {
    const char *px = strstr(desc, "<Pixels ");
    if (!px) px = strstr(desc, ":Pixels ");
    if (!px) return VM_OK;
    int bad = 0;
    double c = xml_number(px, "SizeC", &bad), tt = xml_number(px, "SizeT", &bad);
    double z = xml_number(px, "SizeZ", &bad);
    if ((c > 1) || (tt > 1))
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: OME-XML SizeC=%g SizeT=%g; only one "
                            "channel at one time point is read", file, isnan(c) ? 1 : c,
                            isnan(tt) ? 1 : tt);
    if (!isnan(z) && z != (double)pages)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: OME-XML SizeZ=%g but the stack holds "
                            "%lld pages (OME datasets split over several files are not read)",
                            file, z, (long long)pages);
    static const char *const keys[3] = {"PhysicalSizeX", "PhysicalSizeY", "PhysicalSizeZ"};
    for (int a = 0; a < 3; a++) {
        double s = xml_number(px, keys[a], &bad);
        if (bad)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: OME-XML %s is not a number", file,
                                keys[a]);
        if (isnan(s)) continue;
        char what[40];
        snprintf(what, sizeof what, "OME-XML %s", keys[a]);
        vm_status st = take_spacing(file, what, s, &sp[a], err);
        if (st) return st;
    }
    return VM_OK;
}

/* The files of path: itself, or a folder's .tif/.tiff files in natural order. */
static vm_status list_files(const char *path, tiff_stack *s, vm_error *err) {
    struct stat sb;
    if (stat(path, &sb) != 0)
        return vm_error_set(err, VM_ERR_IO, "%s: cannot open (%s)", path, strerror(errno));
    if (!S_ISDIR(sb.st_mode)) {
        s->files = malloc(sizeof *s->files);
        if (s->files) s->files[0] = malloc(strlen(path) + 1);
        if (!s->files || !s->files[0]) {
            free(s->files);
            s->files = NULL;
            return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
        }
        strcpy(s->files[0], path);
        s->nfiles = 1;
        return VM_OK;
    }
    DIR *d = opendir(path);
    if (!d) return vm_error_set(err, VM_ERR_IO, "%s: cannot open the folder", path);
    size_t cap = 0;
    struct dirent *e;
    vm_status st = VM_OK;
    while (!st && (e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.' || !tiff_name(e->d_name)) continue;
        size_t len = strlen(path) + strlen(e->d_name) + 2;
        char *full = malloc(len);
        if (!full) {
            st = vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
            break;
        }
        snprintf(full, len, "%s/%s", path, e->d_name);
        if (stat(full, &sb) != 0 || !S_ISREG(sb.st_mode)) {
            free(full);
            continue;
        }
        if (s->nfiles == cap) {
            size_t nc = cap ? 2 * cap : 64;
            char **nf = realloc(s->files, nc * sizeof *nf);
            if (!nf) {
                free(full);
                st = vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
                break;
            }
            s->files = nf, cap = nc;
        }
        s->files[s->nfiles++] = full;
    }
    closedir(d);
    if (!st && s->nfiles == 0)
        st = vm_error_set(err, VM_ERR_FORMAT, "%s: no .tif or .tiff file in the folder", path);
    if (!st) qsort(s->files, s->nfiles, sizeof *s->files, natural_qsort);
    return st;
}

/* Appends page (file, dir) to s. */
static vm_status add_page(tiff_stack *s, size_t file, tdir_t dir, int64_t *cap, vm_error *err) {
    if (s->npages == *cap) {
        int64_t nc = *cap ? 2 * *cap : 256;
        size_t *nf = realloc(s->page_file, (size_t)nc * sizeof *nf);
        if (nf) s->page_file = nf;
        tdir_t *nd = nf ? realloc(s->page_dir, (size_t)nc * sizeof *nd) : NULL;
        if (!nd) return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", s->files[file]);
        s->page_dir = nd, *cap = nc;
    }
    s->page_file[s->npages] = file;
    s->page_dir[s->npages++] = dir;
    return VM_OK;
}

/* Reads every page's header: all alike, their order, and the spacing. */
static vm_status scan_stack(const char *path, tiff_stack *s, tiff_open *o, vm_error *err) {
    vm_status st = list_files(path, s, err);
    int64_t cap = 0;
    char *desc = NULL;
    for (size_t i = 0; !st && i < s->nfiles; i++) {
        st = open_file(s, i, o, err);
        for (tdir_t dir = 0; !st; dir++) {
            page_fmt f;
            st = page_format(s->files[i], dir, o, &f, err);
            if (st) break;
            if (s->npages == 0) {
                s->fmt = f;
                const char *d = NULL;
                if (TIFFGetField(o->t, TIFFTAG_IMAGEDESCRIPTION, &d) && d) {
                    desc = malloc(strlen(d) + 1);
                    if (desc) strcpy(desc, d);
                }
            } else if (f.w != s->fmt.w || f.h != s->fmt.h || f.type != s->fmt.type) {
                st = vm_error_set(err, VM_ERR_FORMAT, "%s: page %u is %ux%u %s, but the first "
                                  "page of %s is %ux%u %s", s->files[i], (unsigned)dir + 1,
                                  (unsigned)f.w, (unsigned)f.h, vm_scalar_type_name(f.type),
                                  s->files[0], (unsigned)s->fmt.w, (unsigned)s->fmt.h,
                                  vm_scalar_type_name(s->fmt.type));
                break;
            }
            st = add_page(s, i, dir, &cap, err);
            if (st || !TIFFReadDirectory(o->t)) break;
        }
        if (!st && o->msg.set)
            st = vm_error_set(err, VM_ERR_FORMAT, "%s: corrupt page directory (libtiff: %s)",
                              s->files[i], o->msg.text);
    }
    s->spacing[0] = s->spacing[1] = s->spacing[2] = 1.0;
    if (!st && desc) {
        st = open_file(s, 0, o, err);
        if (!st && !TIFFSetDirectory(o->t, 0))
            st = vm_error_set(err, VM_ERR_FORMAT, "%s: cannot read page 1 again (libtiff: %s)",
                              s->files[0], why(o, "corrupt directory"));
        if (!st && strncmp(desc, "ImageJ=", 7) == 0)
            st = imagej_meta(s->files[0], o->t, desc, s->spacing, err);
        else if (!st && strstr(desc, "<OME"))
            st = ome_meta(s->files[0], desc, s->npages, s->spacing, err);
    }
    free(desc);
    return st;
}

/* Decodes page k of s into dst (w*h floats), strips or tiles. */
static vm_status read_page(const tiff_stack *s, int64_t k, tiff_open *o, float *dst,
                           vm_error *err) {
    const char *file = s->files[s->page_file[k]];
    unsigned page = (unsigned)s->page_dir[k] + 1;
    vm_status st = open_file(s, s->page_file[k], o, err);
    if (st) return st;
    TIFF *t = o->t;
    if (!TIFFSetDirectory(t, s->page_dir[k]))
        return vm_error_set(err, VM_ERR_FORMAT, "%s: cannot read page %u (libtiff: %s)", file,
                            page, why(o, "corrupt directory"));
    const uint32_t w = s->fmt.w, h = s->fmt.h;
    const size_t tsize = vm_scalar_type_size(s->fmt.type);
    int tiled = TIFFIsTiled(t);
    tmsize_t bsize = tiled ? TIFFTileSize(t) : TIFFStripSize(t);
    uint32_t tw = w, th = 0;
    if (tiled) {
        if (!TIFFGetField(t, TIFFTAG_TILEWIDTH, &tw) || !TIFFGetField(t, TIFFTAG_TILELENGTH, &th) ||
            tw == 0 || th == 0)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: page %u has no tile size", file, page);
    } else {
        TIFFGetFieldDefaulted(t, TIFFTAG_ROWSPERSTRIP, &th);
        if (th == 0 || th > h) th = h;
    }
    size_t need = (size_t)tw * th * tsize;
    if (bsize <= 0 || (size_t)bsize < need)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: page %u: %s of %lld bytes cannot hold its "
                            "%ux%u samples (libtiff: %s)", file, page, tiled ? "tile" : "strip",
                            (long long)bsize, (unsigned)tw, (unsigned)th,
                            why(o, "inconsistent sizes"));
    unsigned char *buf = malloc((size_t)bsize);
    if (!buf) return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory for a strip", file);
    uint32_t nchunks = tiled ? TIFFNumberOfTiles(t) : TIFFNumberOfStrips(t);
    for (uint32_t y = 0; !st && y < h; y += th) {
        uint32_t rows = h - y < th ? h - y : th;
        for (uint32_t x = 0; !st && x < w; x += tw) {
            uint32_t c = tiled ? TIFFComputeTile(t, x, y, 0, 0) : TIFFComputeStrip(t, y, 0);
            /* a strip holds only its rows; a tile is always whole */
            size_t want = tiled ? need : (size_t)rows * w * tsize;
            tmsize_t got = c >= nchunks ? -1
                           : tiled ? TIFFReadEncodedTile(t, c, buf, (tmsize_t)want)
                                   : TIFFReadEncodedStrip(t, c, buf, (tmsize_t)want);
            if (got < 0 || (size_t)got < want) {
                st = vm_error_set(err, VM_ERR_FORMAT, "%s: page %u: %s %u is truncated or "
                                  "corrupt (libtiff: %s)", file, page, tiled ? "tile" : "strip",
                                  (unsigned)c, why(o, "short read"));
                break;
            }
            uint32_t cols = w - x < tw ? w - x : tw;
            for (uint32_t r = 0; r < rows; r++)
                vm__samples_to_float_serial(buf + (size_t)r * tw * tsize, s->fmt.type, 0, cols,
                                            dst + (size_t)(y + r) * w + x);
        }
    }
    free(buf);
    return st;
}

vm_status vm__read_tiff(const char *path, const vm__slab *rq, vm_volume *v, vm_error *err) {
    memset(v, 0, sizeof *v);
    tiff_stack s;
    memset(&s, 0, sizeof s);
    tiff_open o;
    memset(&o, 0, sizeof o);
    o.index = (size_t)-1;
    vm_status st = scan_stack(path, &s, &o, err);
    size_t count, first, n;
    int64_t dims[3] = {s.fmt.w, s.fmt.h, s.npages};
    if (!st) st = vm__slab_check(path, rq, dims, vm_scalar_type_size(s.fmt.type), &count,
                                 &first, &n, err);
    if (!st) {
        const double origin[3] = {0, 0, 0}, dir[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
        vm__volume_set_header(v, dims, s.fmt.type, s.spacing, origin, dir, "tiff");
    }
    if (!st && !rq->header_only) {
        st = vm__slab_alloc(path, rq, n, v, err);
        int64_t z0 = rq->all ? 0 : rq->z0, z1 = rq->all ? s.npages : rq->z1;
        size_t plane = (size_t)s.fmt.w * s.fmt.h;
        for (int64_t k = z0; !st && k < z1; k++)
            st = read_page(&s, k, &o, v->data + plane * (size_t)(k - z0), err);
    }
    if (!st) vm__slab_finish(v, rq);
    close_open(&o);
    stack_free(&s);
    if (st) vm__slab_release(v, rq);
    return st;
}

#endif

vm_status vm_volume_read_tiff(const char *path, vm_volume *v, vm_error *err) {
    return vm__read_tiff(path, &vm__slab_whole, v, err);
}
