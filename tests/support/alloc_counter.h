#pragma once
// Heap allocations of a whole test binary, counted by the replacement global operator new in alloc_counter.cc (linked
// into every module test binary). No-allocation tests compare two readings.

namespace rmpmarl::testing {

/// number of global operator new / new[] calls so far (all threads).
long AllocationCount();

}  // namespace rmpmarl::testing
