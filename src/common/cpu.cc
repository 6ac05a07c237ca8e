// What the CPU running this process can execute.
#include "rmpmarl/common/cpu.h"

namespace rmpmarl {

bool CpuHasAvx2Fma() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
  return false;
#endif
}

}  // namespace rmpmarl
