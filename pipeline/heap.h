// How the process's heap is kept: settings made once, at the start of main.
#pragma once

#include <cstddef>

namespace shadowsg {

// Freed large blocks stay in the heap for reuse (glibc: no mmap below 32 MB,
// no trimming below 1 GB).
void KeepFreedMemory();

// Whether the kernel gives transparent huge pages where a program asks
// (policy `madvise`, Debian's default; `always` gives them unasked, `never`
// not at all).
bool KernelGivesHugePagesOnRequest();

// Where the kernel gives transparent huge pages on request (`madvise`):
// every thread allocates from one heap, grown by 1 GB of address space at
// once, advised MADV_HUGEPAGE and never trimmed. Returns the bytes advised (0: none, e.g.
// another policy, another allocator, or no glibc). Call before any thread starts.
size_t AskHugePagesForTheHeap();

}  // namespace shadowsg
