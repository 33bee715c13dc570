// AskHugePagesForTheHeap (pipeline/heap.h): where the kernel gives huge pages
// on request, a span of the heap is advised for them and the memory the
// program then allocates lies in it.
#include "pipeline/heap.h"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

namespace shadowsg {
namespace {

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kOwnAllocator = true;  // the sanitizer's allocator, not glibc's heap
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kOwnAllocator = true;
#else
constexpr bool kOwnAllocator = false;
#endif
#else
constexpr bool kOwnAllocator = false;
#endif

// The mappings of this process advised for huge pages ("hg" among the
// VmFlags of /proc/self/smaps): [begin, end) each.
std::vector<std::pair<uintptr_t, uintptr_t>> AdvisedMappings() {
  std::ifstream smaps("/proc/self/smaps");
  std::vector<std::pair<uintptr_t, uintptr_t>> advised;
  std::string line;
  uintptr_t begin = 0, end = 0;
  while (std::getline(smaps, line)) {
    if (line.rfind("VmFlags:", 0) == 0) {
      std::istringstream flags(line.substr(8));
      for (std::string f; flags >> f;)
        if (f == "hg") advised.emplace_back(begin, end);
    } else if (line.find('-') != std::string::npos && std::isxdigit(static_cast<unsigned char>(line[0]))) {
      std::istringstream range(line);
      char dash;
      range >> std::hex >> begin >> dash >> end;
    }
  }
  return advised;
}

TEST(Heap, AskedSpanIsAdvisedForHugePagesAndServesAllocations) {
  if (kOwnAllocator || !KernelGivesHugePagesOnRequest())
    GTEST_SKIP() << "no glibc heap here, or the kernel's huge-page policy is not `madvise`";
  KeepFreedMemory();
  const size_t advised = AskHugePagesForTheHeap();
  EXPECT_GE(advised, size_t{1} << 29);  // most of the 1 GB span
  // A block of the solver's size now lies in an advised mapping (all but
  // the part below the span's first 2 MB boundary, where the heap was).
  constexpr size_t kBlock = size_t{8} << 20;
  char* volatile block = static_cast<char*>(std::malloc(kBlock));
  ASSERT_NE(block, nullptr);
  block[0] = 1;
  const uintptr_t at = reinterpret_cast<uintptr_t>(block);
  size_t covered = 0;
  for (const auto& [begin, end] : AdvisedMappings())
    if (begin < at + kBlock && end > at) covered += std::min(end, at + kBlock) - std::max(begin, at);
  std::free(block);
  EXPECT_GE(covered, kBlock * 3 / 4) << "of an 8 MB block, only " << covered << " bytes in huge-page mappings";
}

}  // namespace
}  // namespace shadowsg
