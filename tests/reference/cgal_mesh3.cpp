/* SPDX-License-Identifier: BSD-3-Clause */
// cgal_mesh3 — the CGAL Mesh_3 reference for tests/reference and bench/run.
//
// Meshes a labeled image (an .inr written by tests/reference/refstats.py: label 1 = material,
// 0 = outside) with CGAL's labeled-image domain and the standard Mesh_3 criteria, then writes
// the tetrahedra of the complex as plain text:
//   points N / N lines "x y z" / tets M / M lines "a b c d" (0-based, CGAL's orientation)
// and prints one JSON line on stdout: {"points":N,"tets":M,"mesh_seconds":S}.
// Coordinates are those of the image (voxel i at i * voxel size); the caller applies the
// volume's origin and direction. Only CGAL's documented API is used; nothing is linked
// beyond CGAL's header-only library and GMP/MPFR.
//
// usage: cgal_mesh3 IN.inr OUT.txt FACET_ANGLE FACET_SIZE FACET_DISTANCE RADIUS_EDGE CELL_SIZE
//                   [--no-optimize]
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Image_3.h>
#include <CGAL/Labeled_mesh_domain_3.h>
#include <CGAL/Mesh_complex_3_in_triangulation_3.h>
#include <CGAL/Mesh_criteria_3.h>
#include <CGAL/Mesh_triangulation_3.h>
#include <CGAL/make_mesh_3.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>

typedef CGAL::Exact_predicates_inexact_constructions_kernel K;
typedef CGAL::Labeled_mesh_domain_3<K> Mesh_domain;
typedef CGAL::Mesh_triangulation_3<Mesh_domain, CGAL::Default, CGAL::Sequential_tag>::type Tr;
typedef CGAL::Mesh_complex_3_in_triangulation_3<Tr> C3t3;
typedef CGAL::Mesh_criteria_3<Tr> Mesh_criteria;

namespace params = CGAL::parameters;

static double number(const char *text, const char *what) {
    char *end = nullptr;
    double v = std::strtod(text, &end);
    if (end == text || *end != '\0' || !(v >= 0)) {
        std::fprintf(stderr, "cgal_mesh3: bad %s '%s'\n", what, text);
        std::exit(2);
    }
    return v;
}

int main(int argc, char **argv) {
    if (argc < 8) {
        std::fprintf(stderr, "usage: cgal_mesh3 IN.inr OUT.txt FACET_ANGLE FACET_SIZE "
                             "FACET_DISTANCE RADIUS_EDGE CELL_SIZE [--no-optimize]\n");
        return 2;
    }
    const double facet_angle = number(argv[3], "facet angle");
    const double facet_size = number(argv[4], "facet size");
    const double facet_distance = number(argv[5], "facet distance");
    const double radius_edge = number(argv[6], "radius-edge ratio");
    const double cell_size = number(argv[7], "cell size");
    const bool optimize = !(argc > 8 && std::strcmp(argv[8], "--no-optimize") == 0);

    CGAL::Image_3 image;
    if (!image.read(argv[1])) {
        std::fprintf(stderr, "cgal_mesh3: cannot read %s\n", argv[1]);
        return 2;
    }
    // Same mesh on every run: a fixed seed for the domain's and the optimizers' randomness.
    CGAL::get_default_random() = CGAL::Random(12345);
    CGAL::Random rng(12345);

    auto start = std::chrono::steady_clock::now();
    Mesh_domain domain =
        Mesh_domain::create_labeled_image_mesh_domain(image, params::p_rng = &rng);
    Mesh_criteria criteria(params::facet_angle = facet_angle, params::facet_size = facet_size,
                           params::facet_distance = facet_distance,
                           params::cell_radius_edge_ratio = radius_edge,
                           params::cell_size = cell_size);
    // make_mesh_3's defaults: sliver perturbation and exudation on, Lloyd and ODT off.
    C3t3 c3t3 = optimize ? CGAL::make_mesh_3<C3t3>(domain, criteria)
                         : CGAL::make_mesh_3<C3t3>(domain, criteria, params::no_perturb(),
                                                   params::no_exude());
    double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    std::map<Tr::Vertex_handle, long> index;
    std::vector<Tr::Vertex_handle> order;
    for (auto c = c3t3.cells_in_complex_begin(); c != c3t3.cells_in_complex_end(); ++c)
        for (int i = 0; i < 4; ++i) {
            Tr::Vertex_handle v = c->vertex(i);
            if (index.emplace(v, (long)order.size()).second) order.push_back(v);
        }
    std::ofstream out(argv[2]);
    if (!out) {
        std::fprintf(stderr, "cgal_mesh3: cannot write %s\n", argv[2]);
        return 2;
    }
    out.precision(17);
    out << "points " << order.size() << "\n";
    for (const Tr::Vertex_handle &v : order) {
        const auto p = c3t3.triangulation().point(v);  // weighted point: x y z of its centre
        out << p.x() << " " << p.y() << " " << p.z() << "\n";
    }
    out << "tets " << c3t3.number_of_cells_in_complex() << "\n";
    for (auto c = c3t3.cells_in_complex_begin(); c != c3t3.cells_in_complex_end(); ++c)
        out << index[c->vertex(0)] << " " << index[c->vertex(1)] << " " << index[c->vertex(2)]
            << " " << index[c->vertex(3)] << "\n";
    out.close();
    if (!out) {
        std::fprintf(stderr, "cgal_mesh3: write error on %s\n", argv[2]);
        return 2;
    }
    std::printf("{\"points\": %zu, \"tets\": %zu, \"mesh_seconds\": %.6f}\n", order.size(),
                (size_t)c3t3.number_of_cells_in_complex(), seconds);
    return 0;
}
