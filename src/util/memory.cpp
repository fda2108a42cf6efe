// # implicit: memory hints (implementation)

#include "memory.h"

#include <cstdint>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace implicit {

bool advise_huge_pages(void* data, size_t bytes) {
  // The whole huge pages inside the range: madvise needs page alignment, and
  // advising memory outside the range would touch someone else's data.
  auto begin = ((uintptr_t)data + huge_page_bytes - 1) & ~(huge_page_bytes - 1);
  auto end   = ((uintptr_t)data + bytes) & ~(huge_page_bytes - 1);
  if (data == nullptr || end <= begin) return false;
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  return madvise((void*)begin, end - begin, MADV_HUGEPAGE) == 0;
#else
  return false;
#endif
}

}  // namespace implicit
