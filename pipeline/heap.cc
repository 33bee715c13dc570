#include "pipeline/heap.h"

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <string>
#if defined(__GLIBC__)
#include <malloc.h>
#include <sys/mman.h>
#include <unistd.h>
#endif

namespace shadowsg {

// The solver allocates and frees matrices of 1-30 MB many times a second
// (dictionary columns, Jacobians, cone tables). glibc serves those by mmap
// and returns them on free, so each one faults its pages in again (12-35 %
// of the fit's set-up time in perf). Served from the heap and kept, they are
// reused: fast sunsky solve 1.99-2.33 s -> 1.85-1.96 s (2 threads, 3 runs
// each), peak memory 267 -> 290 MB.
void KeepFreedMemory() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 32 << 20);  // glibc's upper limit for this setting
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
#endif
}

// Even kept, each page is faulted in once: a solve touches 200-350 MB, about
// 40000-90000 faults of 4 KB pages, 6 % of a balanced solve's CPU time in
// perf on the development VM. In 2 MB pages (transparent huge pages, which
// Debian's kernels give where a program asks: `madvise`) fast solves took
// 0.85-0.92x the time, balanced ones 0.91x, with the same results (paired,
// 3 seeds x 8 scenes; solver/EXPERIMENTS.md, stop 64).
// The heap is grown by 1 GB at once (address space only; pages come as they
// are touched) and that span is asked for huge pages, and every thread
// allocates from it (one arena: the others would be mapped apart, in 4 KB
// pages). Past the span the heap grows as before. glibc's own switch for
// this (the glibc.malloc.hugetlb tunable) is read only at start-up, from the
// environment.
bool KernelGivesHugePagesOnRequest() {
  std::ifstream policy("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string line;
  return std::getline(policy, line) && line.find("[madvise]") != std::string::npos;
}

size_t AskHugePagesForTheHeap() {
#if defined(__GLIBC__)
  if (!KernelGivesHugePagesOnRequest()) return 0;
  constexpr size_t kSpan = size_t{1} << 30, kHugePage = size_t{2} << 20;
  mallopt(M_ARENA_MAX, 1);
  // Never trimmed: at KeepFreedMemory's 1 GB threshold the first free that
  // reached the span's top gave the span back (the heap then grew again in
  // unadvised pages).
  mallopt(M_TRIM_THRESHOLD, std::numeric_limits<int>::max());
  mallopt(M_TOP_PAD, static_cast<int>(kSpan));
  const uintptr_t before = reinterpret_cast<uintptr_t>(sbrk(0));
  // Larger than anything the start-up left free on the heap, below the
  // mmap threshold: the heap must grow to serve it. (The write keeps the
  // compiler from dropping the pair.)
  char* volatile probe = static_cast<char*>(std::malloc(24 << 20));
  if (probe) probe[0] = 1;
  std::free(probe);
  const uintptr_t after = reinterpret_cast<uintptr_t>(sbrk(0));
  mallopt(M_TOP_PAD, 128 << 10);  // glibc's default
  const uintptr_t begin = (before + kHugePage - 1) & ~(kHugePage - 1);
  if (after <= begin || madvise(reinterpret_cast<void*>(begin), after - begin, MADV_HUGEPAGE) != 0) return 0;
  return after - begin;
#else
  return 0;
#endif
}

}  // namespace shadowsg
