#pragma once
// Heap allocations of the whole sim_tests binary, counted by the global operator new that no_alloc_test.cc replaces
// (one replacement per binary; every no-allocation test shares it through this function).

namespace rmpmarl::sim::testing {

/// number of global operator new / new[] calls so far (all threads).
long AllocationCount();

}  // namespace rmpmarl::sim::testing
