#pragma once

#include <Eigen/Core>
#include <cstddef>

namespace shadowsg {

// Eigen cuts its matrix products into blocks sized from the cache sizes the
// CPU reports, and the blocks fix the order of every sum. Two machines that
// report different caches round the same product differently, and the `sg`
// solver's size path is far from convex, so last-bit differences can end in
// different lobes: the same seed gave a different lighting.json when only
// the reported sizes changed (pub_torus_sunsky, fast, seed 10: three sizes,
// three files). With the sizes pinned, a seed's result no longer depends on
// what the CPU reports. The values are what the stop-48 development machine
// (a 2-core AMD EPYC) reports for L1 and L2, so its results stay as they
// were (the same lighting.json on four solves); L3 changed no block of the
// solver's products there.
inline constexpr std::ptrdiff_t kPinnedL1Cache = 32 * 1024;
inline constexpr std::ptrdiff_t kPinnedL2Cache = 512 * 1024;
inline constexpr std::ptrdiff_t kPinnedL3Cache = 32 * 1024 * 1024;

// Eigen's own threading is turned off as well: a product it splits among
// threads is blocked for that (a shorter depth block than on one thread), so
// one seed rounded differently on one thread and on two. The solver's
// parallel loops share work in fixed pieces instead
// (RowParallelProduct, solver/row_parallel_product.h).
//
// Process-wide: call once, before the first product (the CLI does, in
// MakeContext).
inline void PinEigenBlocking() {
  Eigen::setCpuCacheSizes(kPinnedL1Cache, kPinnedL2Cache, kPinnedL3Cache);
  Eigen::setNbThreads(1);
}

}  // namespace shadowsg
