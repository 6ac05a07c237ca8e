#pragma once
/// What the CPU running this process can execute, for the kernels that choose a code path at run time.

namespace rmpmarl {

/// true on an x86-64 CPU with AVX2 and FMA (the AVX2 kernels: the policy runtime's dense layers, the coupled layer's
/// collision leaves); false on every other CPU.
bool CpuHasAvx2Fma();

}  // namespace rmpmarl
