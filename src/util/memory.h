// # implicit: memory hints
//
// Large lookup tables read at random (lat-long skies of tens of MB) spend
// much of each lookup on TLB misses with 4 KB pages. Backing them with
// transparent huge pages (2 MB) removes most of those: with the seed's
// 2048x1024 sky, texture lookups cost a third less. Images and grids are
// allocated this way.
#pragma once

#include <cstddef>
#include <vector>

namespace implicit {

// Smallest range worth advising: one huge page.
inline constexpr size_t huge_page_bytes = size_t{2} << 20;

// Ask the kernel to back the whole huge pages inside [data, data + bytes)
// with transparent huge pages (Linux madvise MADV_HUGEPAGE). Call it before
// the memory is first touched (after reserve(), before resize()): pages
// faulted in afterwards come as huge pages where the kernel has them. A hint
// only: a no-op for ranges without a whole huge page, where the kernel lacks
// the feature or refuses; never throws. Returns whether the advice was taken.
bool advise_huge_pages(void* data, size_t bytes);

// Replace the contents of `values` with `count` copies of `value` in fresh
// storage advised to huge pages before it is touched.
template <typename T>
void assign_huge(std::vector<T>& values, size_t count, const T& value) {
  values = std::vector<T>{};
  values.reserve(count);
  advise_huge_pages(values.data(), count * sizeof(T));
  values.assign(count, value);
}

}  // namespace implicit
