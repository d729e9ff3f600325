/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/mesher/test_threads.c — the parallel stages give the same bytes for any thread count:
 * denoising (bilateral, diffusion), tet meshing (uniform and adaptive: classification, octree,
 * patch vertices, slab emission), graded meshing (the coarsening's checks), VTU compression,
 * the mesh checks and the tet quality pass. */
#include <stdlib.h>
#include <string.h>
#include "test.h"

static unsigned char *slurp(const char *path, size_t *len) {
    FILE *fp = fopen(path, "rb");
    if (!fp) return NULL;
    fseek(fp, 0, SEEK_END);
    long n = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    unsigned char *buf = malloc(n > 0 ? (size_t)n : 1);
    *len = buf ? fread(buf, 1, (size_t)n, fp) : 0;
    fclose(fp);
    return buf;
}

static const int counts[] = {1, 2, 3};

static void denoisingIsTheSameForOneTwoAndThreeThreads(void) {
    vm_volume v, ref[2];
    vm_error err;
    int before = vm_set_threads(1);
    CHECK_OK(vm_phantom_make(VM_PHANTOM_GENUS3, 40, 0.4, 7, &v, NULL, &err), &err);
    for (size_t t = 0; t < sizeof counts / sizeof counts[0]; t++) {
        vm_set_threads(counts[t]);
        vm_volume b, d;
        CHECK_OK(vm_denoise_bilateral(&v, 1.5, 0.5, &b, NULL, NULL, &err), &err);
        CHECK_OK(vm_denoise_diffusion(&v, 0.5, 0, 6, &d, NULL, NULL, &err), &err);
        size_t bytes = vm_volume_count(&v) * sizeof(float);
        if (t == 0) {
            ref[0] = b;
            ref[1] = d;
            continue;
        }
        CHECK_MSG(memcmp(b.data, ref[0].data, bytes) == 0, "bilateral differs at %d threads",
                  counts[t]);
        CHECK_MSG(memcmp(d.data, ref[1].data, bytes) == 0, "diffusion differs at %d threads",
                  counts[t]);
        vm_volume_free(&b);
        vm_volume_free(&d);
    }
    vm_volume_free(&ref[0]);
    vm_volume_free(&ref[1]);
    vm_volume_free(&v);
    vm_set_threads(before);
}

static void vtuBytesAndMeshChecksAreTheSameForAnyThreadCount(void) {
    vm_volume v;
    vm_mesh m;
    vm_error err;
    vm_mesh_options o;
    int before = vm_set_threads(1);
    CHECK_OK(vm_phantom_make(VM_PHANTOM_TORUS, 40, 0.0, 1, &v, NULL, &err), &err);
    vm_mesh_options_default(&o);
    CHECK_OK(vm_mesh_volume(&v, &o, &m, NULL, &err), &err);
    unsigned char *ref = NULL;
    size_t ref_len = 0;
    vm_mesh_report ref_r;
    for (size_t t = 0; t < sizeof counts / sizeof counts[0]; t++) {
        vm_set_threads(counts[t]);
        const char *path = vm_test_tmp("threads.vtu");
        CHECK_OK(vm_mesh_write_vtu(path, &m, 1, &err), &err);
        size_t len = 0;
        unsigned char *bytes = slurp(path, &len);
        vm_mesh_report r;
        CHECK_OK(vm_mesh_check(&m, &r, &err), &err);
        CHECK(bytes != NULL && len > 1000);
        if (t == 0) {
            ref = bytes;
            ref_len = len;
            ref_r = r;
            CHECK(r.inverted == 0 && r.boundary_closed && r.boundary_euler == 0);
            continue;
        }
        CHECK_MSG(len == ref_len && memcmp(bytes, ref, len) == 0,
                  "VTU bytes differ at %d threads", counts[t]);
        CHECK_MSG(memcmp(&r, &ref_r, sizeof r) == 0, "mesh check differs at %d threads",
                  counts[t]);
        free(bytes);
    }
    free(ref);
    vm_mesh_free(&m);
    vm_volume_free(&v);
    vm_set_threads(before);
}

/* dst = the points, tets and regions of src (no fields), for one run of the pass. */
static void copy_tets(const vm_mesh *src, vm_mesh *dst) {
    vm_error err;
    vm_mesh_init(dst, VM_TET4);
    CHECK_OK(vm_mesh_reserve(dst, src->npoints, src->ncells, &err), &err);
    memcpy(dst->points, src->points, 3 * src->npoints * sizeof *dst->points);
    memcpy(dst->cells, src->cells, 4 * src->ncells * sizeof *dst->cells);
    memcpy(dst->region, src->region, src->ncells * sizeof *dst->region);
    dst->npoints = src->npoints;
    dst->ncells = src->ncells;
}

static void qualityPassGivesTheSameMeshForOneTwoAndThreeThreads(void) {
    vm_volume v;
    vm_mesh m0;
    vm_error err;
    vm_mesh_options o;
    int before = vm_set_threads(1);
    /* a noisy genus-3 phantom: many slivers for the pass to work on */
    CHECK_OK(vm_phantom_make(VM_PHANTOM_GENUS3, getenv("VM_SANITIZED") ? 28 : 40, 0.3, 3, &v,
                             NULL, &err),
             &err);
    vm_mesh_options_default(&o);
    CHECK_OK(vm_mesh_volume(&v, &o, &m0, NULL, &err), &err);
    vm_mesh_report r0;
    CHECK_OK(vm_mesh_check(&m0, &r0, &err), &err);
    vm_mesh ref;
    vm_improve_report ref_r;
    memset(&ref, 0, sizeof ref);
    for (size_t t = 0; t < sizeof counts / sizeof counts[0]; t++) {
        vm_set_threads(counts[t]);
        vm_mesh m;
        copy_tets(&m0, &m);
        vm_improve_options io;
        vm_improve_options_default(&io);
        io.mark_unfixed = 1;
        vm_test_progress_log prog = {"improve", 0, 0, 0, 0, 0, 0.0, 0.0};
        io.progress = vm_test_progress;
        io.progress_user = &prog;
        vm_improve_report r;
        CHECK_OK(vm_mesh_improve(&m, &v, &io, &r, &err), &err);
        /* the bar starts with the set-up, only moves forward and ends full */
        CHECK_MSG(prog.calls >= 6 && prog.backwards == 0 && prog.last == 1.0 &&
                      prog.total == 1.0 && prog.total_changed == 0 && prog.other_stage == 0,
                  "progress: %d calls, %d backwards, last %g of %g", prog.calls, prog.backwards,
                  prog.last, prog.total);
        r.seconds = 0.0;
        if (t == 0) {
            vm_mesh_report mr;
            CHECK_OK(vm_mesh_check(&m, &mr, &err), &err);
            CHECK(r.slivers_10_before > 0 && r.collapses + r.moves > 0); /* it had work */
            CHECK(mr.inverted == 0 && r.inverted_after == 0);
            /* the pass keeps the boundary topology */
            CHECK(mr.boundary_closed && r0.boundary_closed);
            CHECK(mr.boundary_euler == r0.boundary_euler && mr.components == r0.components);
            CHECK(r.min_dihedral_after > r.min_dihedral_before);
            CHECK_MSG(fabs(r.volume_after - r.volume_before) < 0.03 * r.volume_before,
                      "volume %g -> %g", r.volume_before, r.volume_after);
            ref = m;
            ref_r = r;
            continue;
        }
        CHECK_MSG(m.npoints == ref.npoints && m.ncells == ref.ncells &&
                      memcmp(m.points, ref.points, 3 * m.npoints * sizeof *m.points) == 0 &&
                      memcmp(m.cells, ref.cells, 4 * m.ncells * sizeof *m.cells) == 0 &&
                      memcmp(m.region, ref.region, m.ncells * sizeof *m.region) == 0,
                  "improved mesh differs at %d threads", counts[t]);
        CHECK_MSG(m.ncell_fields == 1 && ref.ncell_fields == 1 &&
                      memcmp(m.cell_fields[0].data, ref.cell_fields[0].data,
                             m.ncells * sizeof(double)) == 0,
                  "improve_unfixed differs at %d threads", counts[t]);
        CHECK_MSG(memcmp(&r, &ref_r, sizeof r) == 0, "improve report differs at %d threads",
                  counts[t]);
        vm_mesh_free(&m);
    }
    vm_mesh_free(&ref);
    vm_mesh_free(&m0);
    vm_volume_free(&v);
    vm_set_threads(before);
}

/* Two regions (split by a grid plane through the phantom, so the interface is flat and its
 * vertices move in it) and a cell field holding each input tet's id: the probes and the
 * parent ids of the pass give the same mesh on 1, 2 and 3 threads, and every output tet
 * carries the field and region of the input tet it descends from. */
static void qualityPassWithTwoRegionsAndACellFieldIsTheSameForAnyThreadCount(void) {
    vm_volume v;
    vm_mesh m0;
    vm_error err;
    vm_mesh_options o;
    int before = vm_set_threads(1);
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, getenv("VM_SANITIZED") ? 24 : 32, 0.3, 5, &v,
                             NULL, &err),
             &err);
    vm_mesh_options_default(&o);
    CHECK_OK(vm_mesh_volume(&v, &o, &m0, NULL, &err), &err);
    double zmid = 0.0;
    for (size_t i = 0; i < m0.npoints; i++) zmid += m0.points[3 * i + 2] / (double)m0.npoints;
    zmid = floor(zmid); /* a grid plane: the inner cells' tets lie on one side of it */
    double *id = malloc(m0.ncells * sizeof *id);
    CHECK(id != NULL);
    for (size_t t = 0; t < m0.ncells; t++) {
        double z = 0.0;
        for (int k = 0; k < 4; k++) z += 0.25 * m0.points[3 * (size_t)m0.cells[4 * t + k] + 2];
        m0.region[t] = z < zmid ? 1 : 2;
        id[t] = (double)t;
    }
    CHECK_OK(vm_mesh_set_field(&m0, 1, "input_id", 1, id, &err), &err);
    free(id);
    vm_mesh ref;
    vm_improve_report ref_r;
    memset(&ref, 0, sizeof ref);
    for (size_t t = 0; t < sizeof counts / sizeof counts[0]; t++) {
        vm_set_threads(counts[t]);
        vm_mesh m;
        copy_tets(&m0, &m);
        CHECK_OK(vm_mesh_set_field(&m, 1, "input_id", 1, m0.cell_fields[0].data, &err), &err);
        vm_improve_options io;
        vm_improve_options_default(&io);
        vm_improve_report r;
        CHECK_OK(vm_mesh_improve(&m, &v, &io, &r, &err), &err);
        r.seconds = 0.0;
        CHECK(m.ncell_fields == 1);
        if (t == 0) {
            vm_mesh_report mr;
            CHECK_OK(vm_mesh_check(&m, &mr, &err), &err);
            CHECK(r.moves > 0 && r.collapses > 0 && r.slivers_10_before > 0);
            CHECK(mr.inverted == 0 && r.inverted_after == 0 && mr.boundary_closed);
            CHECK(r.max_interface_move > 0.0); /* interface vertices moved */
            size_t wrong = 0;
            for (size_t c = 0; c < m.ncells; c++) {
                double f = m.cell_fields[0].data[c];
                size_t k = (size_t)f;
                wrong += !(f >= 0.0 && k < m0.ncells && (double)k == f &&
                           m.region[c] == m0.region[k]);
            }
            CHECK_MSG(wrong == 0, "%zu tets carry a wrong input id or region", wrong);
            CHECK_MSG(fabs(r.volume_after - r.volume_before) < 0.03 * r.volume_before,
                      "volume %g -> %g", r.volume_before, r.volume_after);
            ref = m;
            ref_r = r;
            continue;
        }
        CHECK_MSG(m.npoints == ref.npoints && m.ncells == ref.ncells &&
                      memcmp(m.points, ref.points, 3 * m.npoints * sizeof *m.points) == 0 &&
                      memcmp(m.cells, ref.cells, 4 * m.ncells * sizeof *m.cells) == 0 &&
                      memcmp(m.region, ref.region, m.ncells * sizeof *m.region) == 0 &&
                      memcmp(m.cell_fields[0].data, ref.cell_fields[0].data,
                             m.ncells * sizeof(double)) == 0,
                  "improved two-region mesh differs at %d threads", counts[t]);
        CHECK_MSG(memcmp(&r, &ref_r, sizeof r) == 0, "improve report differs at %d threads",
                  counts[t]);
        vm_mesh_free(&m);
    }
    vm_mesh_free(&ref);
    vm_mesh_free(&m0);
    vm_volume_free(&v);
    vm_set_threads(before);
}

/* The mesh of one run, and that it is a valid closed mesh of the phantom's topology. */
static void mesh_once(const vm_volume *v, int adaptive, int euler, vm_mesh *m) {
    vm_error err;
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.adaptive = adaptive;
    CHECK_OK(vm_mesh_volume(v, &o, m, NULL, &err), &err);
    vm_mesh_report r;
    CHECK_OK(vm_mesh_check(m, &r, &err), &err);
    CHECK_MSG(r.inverted == 0 && r.boundary_closed && r.boundary_euler == euler,
              "adaptive %d: %zu inverted, closed %d, Euler %ld (want %d)", adaptive, r.inverted,
              r.boundary_closed, (long)r.boundary_euler, euler);
}

static void tetMeshesAreByteIdenticalForOneTwoAndThreeThreads(void) {
    /* Big enough that every parallel loop gets several slabs per thread (the emission runs
     * in slabs of 4 layers, 64 slabs a batch: 3 x 24 = 72 edge slabs is two batches). */
    const int n = getenv("VM_SANITIZED") ? 64 : 96;
    static const struct {
        vm_phantom_kind kind;
        int euler;
    } shapes[] = {{VM_PHANTOM_GENUS3, -4}, {VM_PHANTOM_TWO_SPHERES, 4}};
    int before = vm_set_threads(1);
    for (size_t sh = 0; sh < sizeof shapes / sizeof shapes[0]; sh++) {
        vm_volume v;
        vm_error err;
        CHECK_OK(vm_phantom_make(shapes[sh].kind, n, 0.0, 1, &v, NULL, &err), &err);
        for (int adaptive = 0; adaptive < 2; adaptive++) {
            vm_mesh ref;
            vm_set_threads(1);
            mesh_once(&v, adaptive, shapes[sh].euler, &ref);
            CHECK(ref.ncells > 1000);
            for (size_t t = 1; t < sizeof counts / sizeof counts[0]; t++) {
                vm_set_threads(counts[t]);
                vm_mesh m;
                mesh_once(&v, adaptive, shapes[sh].euler, &m);
                CHECK_MSG(m.npoints == ref.npoints && m.ncells == ref.ncells,
                          "shape %zu adaptive %d: %zu points %zu tets at %d threads, %zu %zu "
                          "at 1", sh, adaptive, m.npoints, m.ncells, counts[t], ref.npoints,
                          ref.ncells);
                if (m.npoints == ref.npoints && m.ncells == ref.ncells) {
                    CHECK_MSG(memcmp(m.points, ref.points, 3 * m.npoints * sizeof(double)) == 0,
                              "shape %zu adaptive %d: points differ at %d threads", sh,
                              adaptive, counts[t]);
                    CHECK_MSG(memcmp(m.cells, ref.cells, 4 * m.ncells * sizeof(vm_index)) == 0,
                              "shape %zu adaptive %d: tets differ at %d threads", sh,
                              adaptive, counts[t]);
                }
                vm_mesh_free(&m);
            }
            vm_mesh_free(&ref);
        }
        vm_volume_free(&v);
    }
    vm_set_threads(before);
}

/* The graded mesher (its coarsening checks collapses ahead on threads, then takes them in
 * order) gives the same mesh for any thread count: a noisy genus-3 phantom, whose boundary
 * collapses also spend the net volume budget. */
static void gradedMeshesAreByteIdenticalForOneTwoAndThreeThreads(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_GENUS3, 56, 0.2, 7, &v, NULL, &err), &err);
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.graded = 1;
    int before = vm_set_threads(1);
    vm_mesh ref;
    CHECK_OK(vm_mesh_volume(&v, &o, &ref, NULL, &err), &err);
    vm_mesh_report r;
    CHECK_OK(vm_mesh_check(&ref, &r, &err), &err);
    CHECK_MSG(r.inverted == 0 && r.boundary_closed && ref.ncells > 500,
              "graded: %zu inverted, closed %d, %zu tets", r.inverted, r.boundary_closed,
              ref.ncells);
    for (size_t t = 1; t < sizeof counts / sizeof counts[0]; t++) {
        vm_set_threads(counts[t]);
        vm_mesh m;
        CHECK_OK(vm_mesh_volume(&v, &o, &m, NULL, &err), &err);
        int same = m.npoints == ref.npoints && m.ncells == ref.ncells &&
                   memcmp(m.points, ref.points, 3 * m.npoints * sizeof(double)) == 0 &&
                   memcmp(m.cells, ref.cells, 4 * m.ncells * sizeof(vm_index)) == 0;
        CHECK_MSG(same, "graded: %zu points %zu tets at %d threads, %zu %zu at 1 (or moved)",
                  m.npoints, m.ncells, counts[t], ref.npoints, ref.ncells);
        vm_mesh_free(&m);
    }
    vm_mesh_free(&ref);
    vm_volume_free(&v);
    vm_set_threads(before);
}

/* The contour spectrum sums its layers in a fixed order: the same numbers for any count. */
static void spectrumIsTheSameForOneTwoAndThreeThreads(void) {
    vm_volume v;
    vm_error err;
    int before = vm_set_threads(1);
    CHECK_OK(vm_phantom_make(VM_PHANTOM_TORUS, 48, 0.3, 5, &v, NULL, &err), &err);
    vm_spectrum ref;
    CHECK_OK(vm_spectrum_compute(&v, 64, &ref, &err), &err);
    CHECK(ref.n == 64 && ref.total_volume > 0 && ref.area[32] > 0);
    for (size_t t = 1; t < sizeof counts / sizeof counts[0]; t++) {
        vm_set_threads(counts[t]);
        vm_spectrum s;
        CHECK_OK(vm_spectrum_compute(&v, 64, &s, &err), &err);
        size_t bytes = (size_t)ref.n * sizeof(double);
        CHECK_MSG(s.n == ref.n && s.total_volume == ref.total_volume &&
                      memcmp(s.area, ref.area, bytes) == 0 &&
                      memcmp(s.volume, ref.volume, bytes) == 0 &&
                      memcmp(s.gradient_integral, ref.gradient_integral, bytes) == 0 &&
                      memcmp(s.components, ref.components, (size_t)ref.n * sizeof(int64_t)) == 0,
                  "spectrum differs at %d threads", counts[t]);
        vm_spectrum_free(&s);
    }
    vm_spectrum_free(&ref);
    vm_volume_free(&v);
    vm_set_threads(before);
}

static void threadCountIsSetAndRestored(void) {
    int before = vm_set_threads(2);
    int now = vm_threads();
    CHECK(now == 2 || now == 1); /* 1: built without OpenMP */
    vm_set_threads(before);
    CHECK(vm_threads() == before);
}

TEST_MAIN(T(denoisingIsTheSameForOneTwoAndThreeThreads),
          T(tetMeshesAreByteIdenticalForOneTwoAndThreeThreads),
          T(gradedMeshesAreByteIdenticalForOneTwoAndThreeThreads),
          T(vtuBytesAndMeshChecksAreTheSameForAnyThreadCount),
          T(qualityPassGivesTheSameMeshForOneTwoAndThreeThreads),
          T(qualityPassWithTwoRegionsAndACellFieldIsTheSameForAnyThreadCount),
          T(spectrumIsTheSameForOneTwoAndThreeThreads),
          T(threadCountIsSetAndRestored))
