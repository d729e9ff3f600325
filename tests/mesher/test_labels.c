/* tests/mesher/test_labels.c — multi-material meshes of label volumes: on phantoms with
 * nested, face-sharing, junction and diagonal-contact materials, the whole mesh is valid and
 * conforming, each label's boundary (its faces against anything else) is a closed manifold
 * with the known Euler characteristic, and each label keeps its volume; the frog
 * segmentation keeps all 25 tissues. */
#include <string.h>
#include "test.h"

/* The cells of m with region == label, over the same points. */
static void submesh(const vm_mesh *m, int32_t label, vm_mesh *out) {
    vm_error err;
    vm_mesh_init(out, m->kind);
    size_t n = 0, nn = (size_t)vm_cell_nodes(m->kind);
    for (size_t c = 0; c < m->ncells; c++) n += m->region[c] == label;
    CHECK_OK(vm_mesh_reserve(out, m->npoints, n, &err), &err);
    memcpy(out->points, m->points, 3 * m->npoints * sizeof(double));
    out->npoints = m->npoints;
    for (size_t c = 0; c < m->ncells; c++) {
        if (m->region[c] != label) continue;
        memcpy(out->cells + nn * out->ncells, m->cells + nn * c, nn * sizeof(vm_index));
        out->region[out->ncells++] = label;
    }
}

typedef struct expect {
    int32_t label;
    long euler;
} expect;

/* Checks the whole mesh and every label; returns the number of interface faces. */
static size_t check_labels(const char *name, const vm_mesh *m, const vm_label_stats *st,
                           long euler, const expect *ex, size_t nex, double tol) {
    vm_mesh_report r;
    vm_error err;
    CHECK_OK(vm_mesh_check(m, &r, &err), &err);
    CHECK_MSG(r.inverted == 0, "%s: %zu inverted", name, r.inverted);
    CHECK_MSG(r.overshared_faces == 0, "%s: %zu faces in 3+ cells", name, r.overshared_faces);
    CHECK_MSG(r.boundary_closed && r.boundary_nonmanifold_vertices == 0,
              "%s: outer boundary not a closed manifold", name);
    CHECK_MSG(r.boundary_euler == euler, "%s: outer Euler %ld, expected %ld", name,
              r.boundary_euler, euler);
    CHECK(st->nlabels == nex);
    size_t label_faces = 0;
    double sum = 0;
    for (size_t i = 0; i < nex && i < st->nlabels; i++) {
        const vm_label_info *li = &st->labels[i];
        CHECK(li->label == ex[i].label);
        vm_mesh sub;
        vm_mesh_report s;
        submesh(m, li->label, &sub);
        CHECK_OK(vm_mesh_check(&sub, &s, &err), &err);
        printf("  %s label %d: %zu cells, volume %.1f, voxels %.1f (input %zu), Euler %ld\n", name,
               li->label, sub.ncells, li->mesh_volume, li->voxel_volume, li->input_voxels,
               s.boundary_euler);
        CHECK(sub.ncells == li->elements);
        CHECK_MSG(s.boundary_closed && s.boundary_nonmanifold_vertices == 0,
                  "%s label %d: boundary open or non-manifold (%zu open, %zu nm edges, %zu nm "
                  "vertices)",
                  name, li->label, s.boundary_open_edges, s.boundary_nonmanifold_edges,
                  s.boundary_nonmanifold_vertices);
        CHECK_MSG(s.boundary_euler == ex[i].euler, "%s label %d: Euler %ld, expected %ld", name,
                  li->label, s.boundary_euler, ex[i].euler);
        CHECK_NEAR(s.volume, li->mesh_volume, 1e-9 * li->mesh_volume);
        CHECK_MSG(fabs(li->mesh_volume - li->voxel_volume) <= tol * li->voxel_volume,
                  "%s label %d: volume %.2f vs voxels %.2f", name, li->label, li->mesh_volume,
                  li->voxel_volume);
        label_faces += s.boundary_faces;
        sum += li->mesh_volume;
        vm_mesh_free(&sub);
    }
    CHECK_NEAR(sum, r.volume, 1e-9 * r.volume);
    /* every label face not on the outside is matched by exactly one face of another label */
    CHECK((label_faces - r.boundary_faces) % 2 == 0);
    return (label_faces - r.boundary_faces) / 2;
}

static const struct {
    const char *name;
    int kind, n;
    long euler;
    expect ex[3];
    size_t nex;
    int touching;
} phantoms[] = {
    {"concentric", 0, 48, 2, {{1, 2}, {2, 4}, {3, 4}}, 3, 1},
    {"two-blocks", 1, 48, 2, {{1, 2}, {2, 2}}, 2, 1},
    {"junction", 2, 48, 2, {{1, 2}, {2, 2}, {3, 2}}, 3, 1},
    /* the edge contact is bridged by the topology repair, so label 1 is one body */
    {"diagonal", 3, 50, 2, {{1, 2}, {2, 2}}, 2, 1},
};

static void labelPhantomsGiveConformingMeshesWithManifoldMaterials(void) {
    for (size_t p = 0; p < sizeof phantoms / sizeof phantoms[0]; p++)
        for (int hex = 0; hex < 2; hex++) {
            vm_volume v;
            vm_error err;
            CHECK_OK(vm_label_phantom_make(phantoms[p].kind, phantoms[p].n, &v, &err), &err);
            vm_label_options o;
            vm_label_options_default(&o);
            o.elements = hex ? VM_HEX8 : VM_TET4;
            vm_mesh m;
            vm_label_stats st;
            vm_status s = vm_mesh_labels(&v, &o, &m, &st, &err);
            CHECK_OK(s, &err);
            if (s == VM_OK) {
                char name[64];
                snprintf(name, sizeof name, "%s/%s", phantoms[p].name, hex ? "hex" : "tet");
                CHECK(m.kind == (hex ? VM_HEX8 : VM_TET4));
                size_t iface = check_labels(name, &m, &st, phantoms[p].euler, phantoms[p].ex,
                                            phantoms[p].nex, 0.02);
                CHECK(!phantoms[p].touching || iface > 0);
                printf("  %s: %zu cells, %zu interface faces, %zu topology voxels, %zu relaxed\n",
                       name, m.ncells, iface, st.topology_voxels, st.relaxed_vertices);
                /* the repair is local: the phantoms need it only at the diagonal contacts */
                if (phantoms[p].kind != 3) CHECK(st.topology_voxels == 0);
                for (size_t i = 0; i < st.nlabels; i++)
                    CHECK_MSG(fabs((double)st.labels[i].meshed_voxels -
                                   (double)st.labels[i].input_voxels) <=
                                  0.02 * (double)st.labels[i].input_voxels,
                              "%s label %d: %zu voxels meshed of %zu", name, st.labels[i].label,
                              st.labels[i].meshed_voxels, st.labels[i].input_voxels);
            }
            vm_label_stats_free(&st);
            vm_mesh_free(&m);
            vm_volume_free(&v);
        }
}

static void staircaseMeshHasExactlyTheVoxelVolumes(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_label_phantom_make(0, 32, &v, &err), &err);
    v.spacing[2] = 1.5;
    vm_label_options o;
    vm_label_options_default(&o);
    o.smooth = 0;
    vm_mesh m;
    vm_label_stats st;
    CHECK_OK(vm_mesh_labels(&v, &o, &m, &st, &err), &err);
    for (size_t i = 0; i < st.nlabels; i++) {
        CHECK_NEAR(st.labels[i].mesh_volume, 1.5 * (double)st.labels[i].input_voxels, 1e-6);
        CHECK(st.labels[i].elements == 6 * st.labels[i].input_voxels);
    }
    CHECK(st.smoothed_vertices == 0);
    vm_label_stats_free(&st);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

static void chosenLabelsOnlyAreMeshedAndTheRestIsBackground(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_label_phantom_make(0, 32, &v, &err), &err);
    static const int32_t pick[] = {3, 1};
    vm_label_options o;
    vm_label_options_default(&o);
    o.labels = pick;
    o.nlabels = 2;
    vm_mesh m;
    vm_label_stats st;
    CHECK_OK(vm_mesh_labels(&v, &o, &m, &st, &err), &err);
    static const expect ex[] = {{1, 2}, {3, 4}};
    /* two separate bodies: a ball inside a hollow shell */
    size_t iface = check_labels("labels 1,3", &m, &st, 6, ex, 2, 0.02);
    CHECK(iface == 0);
    for (size_t c = 0; c < m.ncells; c++) CHECK(m.region[c] == 1 || m.region[c] == 3);
    vm_label_stats_free(&st);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

static void leftHandedAnisotropicFrameKeepsElementsPositive(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_label_phantom_make(2, 24, &v, &err), &err);
    v.spacing[0] = 0.5;
    v.spacing[2] = 2.0;
    v.direction[0][0] = -1;
    for (int hex = 0; hex < 2; hex++) {
        vm_label_options o;
        vm_label_options_default(&o);
        o.elements = hex ? VM_HEX8 : VM_TET4;
        vm_mesh m;
        vm_label_stats st;
        CHECK_OK(vm_mesh_labels(&v, &o, &m, &st, &err), &err);
        static const expect ex[] = {{1, 2}, {2, 2}, {3, 2}};
        check_labels(hex ? "mirrored/hex" : "mirrored/tet", &m, &st, 2, ex, 3, 0.03);
        vm_label_stats_free(&st);
        vm_mesh_free(&m);
    }
    vm_volume_free(&v);
}

static void coarseSizeAndIslandFloorKeepTheMeshValid(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_label_phantom_make(1, 48, &v, &err), &err);
    /* a 2-voxel island of label 5 inside block 1, and one lone voxel of 6 in the background */
    v.data[20 + 48 * (20 + 48 * 20)] = 5;
    v.data[21 + 48 * (20 + 48 * 20)] = 5;
    v.data[2 + 48 * (2 + 48 * 2)] = 6;
    vm_label_options o;
    vm_label_options_default(&o);
    o.min_island = 3;
    vm_mesh m;
    vm_label_stats st;
    CHECK_OK(vm_mesh_labels(&v, &o, &m, &st, &err), &err);
    CHECK(st.island_voxels == 3);
    CHECK(st.nlabels == 4);
    if (st.nlabels == 4) {
        CHECK(st.labels[2].label == 5 && st.labels[2].elements == 0);
        CHECK(st.labels[3].label == 6 && st.labels[3].elements == 0);
        CHECK(st.labels[0].meshed_voxels == st.labels[0].input_voxels + 2);
    }
    vm_label_stats_free(&st);
    vm_mesh_free(&m);

    vm_label_options_default(&o);
    o.cell_size = 3;
    CHECK_OK(vm_mesh_labels(&v, &o, &m, &st, &err), &err);
    static const expect ex[] = {{1, 2}, {2, 2}, {5, 0}, {6, 0}};
    check_labels("size 3", &m, &st, 2, ex, 4, 0.03);
    CHECK(st.labels[0].elements > 0 && st.labels[2].elements == 0);
    vm_label_stats_free(&st);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

static void absentLabelAndNonLabelVolumesAreRefusedClearly(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_label_phantom_make(1, 16, &v, &err), &err);
    static const int32_t pick[] = {2, 99};
    vm_label_options o;
    vm_label_options_default(&o);
    o.labels = pick;
    o.nlabels = 2;
    vm_mesh m;
    CHECK(vm_mesh_labels(&v, &o, &m, NULL, &err) == VM_ERR_EMPTY);
    CHECK(strstr(err.message, "label 99 is not in the volume (labels present: 0-2)") != NULL);
    CHECK(strchr(err.message, '\n') == NULL);
    CHECK(m.ncells == 0 && m.points == NULL);
    v.data[7] = 2.5f;
    vm_label_options_default(&o);
    CHECK(vm_mesh_labels(&v, &o, &m, NULL, &err) == VM_ERR_FORMAT);
    CHECK(strstr(err.message, "not an integer label") != NULL);
    memset(v.data, 0, 16 * 16 * 16 * sizeof(float));
    CHECK(vm_mesh_labels(&v, &o, &m, NULL, &err) == VM_ERR_EMPTY);
    vm_volume_free(&v);
}

/* Histogram of regions 0..7 of m into h. */
static void region_counts(const vm_mesh *m, size_t h[8]) {
    memset(h, 0, 8 * sizeof h[0]);
    for (size_t c = 0; c < m->ncells; c++)
        if (m->region[c] >= 0 && m->region[c] < 8) h[m->region[c]]++;
}

static void everyWriterCarriesTheLabels(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_label_phantom_make(2, 16, &v, &err), &err);
    for (int hex = 0; hex < 2; hex++) {
        vm_label_options o;
        vm_label_options_default(&o);
        o.elements = hex ? VM_HEX8 : VM_TET4;
        vm_mesh m;
        vm_label_stats st;
        CHECK_OK(vm_mesh_labels(&v, &o, &m, &st, &err), &err);
        static const expect ex[] = {{1, 2}, {2, 2}, {3, 2}};
        size_t iface = check_labels("writers", &m, &st, 2, ex, 3, 0.03);
        size_t want[8];
        region_counts(&m, want);
        static const char *files[] = {"labels.vtu", "labels.inp", "labels.msh", "labels.mesh"};
        for (size_t f = 0; f < 4; f++) {
            const char *path = vm_test_tmp(files[f]);
            CHECK_OK(vm_mesh_write(path, &m, &err), &err);
            vm_mesh back;
            CHECK_OK(vm_mesh_read(path, &back, &err), &err);
            size_t got[8];
            region_counts(&back, got);
            CHECK_MSG(memcmp(got, want, sizeof got) == 0 && back.ncells == m.ncells,
                      "%s: regions differ after the round trip", files[f]);
            vm_mesh_free(&back);
        }
        /* INP: one ELSET per label and one surface per touching pair, with every face */
        FILE *fp = fopen(vm_test_tmp("labels.inp"), "r");
        CHECK(fp != NULL);
        char line[256];
        size_t faces = 0, surfaces = 0, elsets = 0;
        int in_iface = 0;
        while (fp && fgets(line, sizeof line, fp)) {
            if (line[0] == '*') {
                in_iface = strncmp(line, "*SURFACE, NAME=IFACE_REGION_", 28) == 0;
                surfaces += (size_t)in_iface;
                elsets += strncmp(line, "*ELSET, ELSET=REGION_", 21) == 0;
                continue;
            }
            faces += (size_t)in_iface;
        }
        if (fp) fclose(fp);
        CHECK(elsets == 3);
        CHECK_MSG(surfaces == 3, "%zu interface surfaces, expected 1|2, 1|3, 2|3", surfaces);
        CHECK_MSG(faces == iface, "%zu interface faces in the deck, %zu in the mesh", faces, iface);
        vm_label_stats_free(&st);
        vm_mesh_free(&m);
    }
    vm_volume_free(&v);
}

static void frogKeepsAllTwentyFiveTissues(void) {
    const char *path = vm_test_shared("frogtissue.mhd");
    if (!path) return;
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read(path, &v, &err), &err);
    vm_label_options o;
    vm_label_options_default(&o);
    o.elements = VM_HEX8;
    vm_mesh m;
    vm_label_stats st;
    vm_status s = vm_mesh_labels(&v, &o, &m, &st, &err);
    CHECK_OK(s, &err);
    if (s == VM_OK) {
        CHECK(st.nlabels == 25);
        vm_mesh_report r;
        CHECK_OK(vm_mesh_check(&m, &r, &err), &err);
        CHECK(r.inverted == 0);
        CHECK(r.overshared_faces == 0);
        CHECK(r.boundary_closed && r.boundary_nonmanifold_vertices == 0);
        printf("  frog: %zu hexes, %zu points, %zu topology voxels, %.2f s\n", m.ncells,
               m.npoints, st.topology_voxels, st.seconds);
        for (size_t i = 0; i < st.nlabels; i++) {
            const vm_label_info *li = &st.labels[i];
            CHECK_MSG(li->elements > 0, "frog label %d lost", li->label);
            if (li->input_voxels >= 1000)
                CHECK_MSG(fabs(li->mesh_volume - li->voxel_volume) <= 0.02 * li->voxel_volume,
                          "frog label %d: volume %.0f vs %.0f", li->label, li->mesh_volume,
                          li->voxel_volume);
        }
    }
    vm_label_stats_free(&st);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

TEST_MAIN(T(labelPhantomsGiveConformingMeshesWithManifoldMaterials),
          T(staircaseMeshHasExactlyTheVoxelVolumes),
          T(chosenLabelsOnlyAreMeshedAndTheRestIsBackground),
          T(leftHandedAnisotropicFrameKeepsElementsPositive),
          T(coarseSizeAndIslandFloorKeepTheMeshValid),
          T(absentLabelAndNonLabelVolumesAreRefusedClearly), T(everyWriterCarriesTheLabels),
          T(frogKeepsAllTwentyFiveTissues))
