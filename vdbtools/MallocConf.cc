// SPDX-License-Identifier: Apache-2.0
// Linked into every rockvdb executable (see the top-level CMakeLists.txt).
//
// jemalloc reads this symbol once at start-up (jemalloc(3), "malloc_conf"): back the arenas
// and their metadata with transparent huge pages. A narrow band is tens of thousands of 2 KB
// leaf buffers written once each; with 4 KB pages the first-touch faults alone cost about as
// much as evaluating the field (measured: a cold R = 200 sphere bake 118 ms → 36 ms).
// Without jemalloc the symbol is unused and harmless.
extern "C" {
const char* malloc_conf = "thp:always,metadata_thp:always";
}
