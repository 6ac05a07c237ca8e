#include "rmpmarl/common/error.h"

#include <cstdio>
#include <cstdlib>

namespace rmpmarl {

void AbortInvariant(const char* expr, const char* file, int line, std::string_view message) {
  std::fprintf(stderr, "rmpmarl: internal error: %s at %s:%d: %.*s\n", expr, file, line,
               static_cast<int>(message.size()), message.data());
  std::abort();
}

}  // namespace rmpmarl
