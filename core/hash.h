/* SPDX-License-Identifier: BSD-3-Clause */
/* core/hash.h — one hash mix for every hash table of the library: the 64-bit finaliser of
 * MurmurHash3 (fmix64, Appleby), which spreads every input bit over the whole word. */
#ifndef VM_CORE_HASH_H
#define VM_CORE_HASH_H

#include <stdint.h>
#include <string.h>

/* fmix64: a bijection of 64-bit words whose output bits each depend on every input bit. */
static inline uint64_t vm__hash_mix(uint64_t x) {
    x ^= x >> 33;
    x *= 0xff51afd7ed558ccdull;
    x ^= x >> 33;
    x *= 0xc4ceb9fe1a85ec53ull;
    x ^= x >> 33;
    return x;
}

/* Folds one more word v into the running hash h (h starts at any constant, say 0). */
static inline uint64_t vm__hash_add(uint64_t h, uint64_t v) {
    return vm__hash_mix(h ^ (v + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2)));
}

/* Hash of a point's three coordinates, bit for bit, with -0 and +0 alike. */
static inline uint64_t vm__hash_point(const double p[3]) {
    uint64_t h = 0;
    for (int d = 0; d < 3; d++) {
        double x = p[d] == 0 ? 0.0 : p[d];
        uint64_t u;
        memcpy(&u, &x, sizeof u);
        h = vm__hash_add(h, u);
    }
    return h;
}

#endif
