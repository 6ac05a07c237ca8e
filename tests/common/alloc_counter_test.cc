// The counting operator new family (tests/support/alloc_counter): every variant counts, and memory from one
// variant can be released by another without an allocator mismatch (the case std::stable_sort hits).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <new>
#include <vector>

#include "../support/alloc_counter.h"

namespace {

struct alignas(64) Wide {
  double v[8];
};

// the pointers escape through a volatile so that the compiler cannot elide a new/delete pair (C++14 allows it)
void* volatile g_sink = nullptr;
template <typename T>
T* Escape(T* p) {
  g_sink = p;
  return static_cast<T*>(g_sink);
}

TEST(AllocCounterTest, EveryVariantCounts) {
  const long before = rmpmarl::testing::AllocationCount();
  delete Escape(new int(1));
  delete[] Escape(new int[3]);
  int* nothrow = Escape(new (std::nothrow) int[5]);
  ASSERT_NE(nothrow, nullptr);
  delete[] nothrow;
  Wide* aligned = Escape(new Wide);  // operator new(size_t, align_val_t)
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(aligned) % 64, 0u);
  delete aligned;
  Wide* aligned_array = Escape(new Wide[3]);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(aligned_array) % 64, 0u);
  delete[] aligned_array;
  EXPECT_EQ(rmpmarl::testing::AllocationCount() - before, 5);
}

// std::stable_sort takes its buffer with nothrow new and gives it back with the plain delete
TEST(AllocCounterTest, StableSortBufferIsCountedAndReleasedConsistently) {
  std::vector<int> v(1000);
  for (int i = 0; i < 1000; ++i) v[i] = (i * 7919) % 1000;
  const long before = rmpmarl::testing::AllocationCount();
  std::stable_sort(v.begin(), v.end());
  EXPECT_TRUE(std::is_sorted(v.begin(), v.end()));
  EXPECT_GE(rmpmarl::testing::AllocationCount() - before, 1);
}

}  // namespace
