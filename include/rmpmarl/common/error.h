#pragma once
/// Errors by kind (Drake): bad user input throws `InputError` with a message that names the file/key and says
/// expected vs got; a broken internal invariant aborts through `RMPMARL_ASSERT`.
#include <stdexcept>
#include <string>
#include <string_view>

namespace rmpmarl {

/// Thrown for user input that is missing, malformed or out of range; `what()` is meant for the user.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// prints "rmpmarl: internal error: <expr> at <file>:<line>: <message>" and aborts.
[[noreturn]] void AbortInvariant(const char* expr, const char* file, int line, std::string_view message);

}  // namespace rmpmarl

/// Always-on check of an internal invariant (not for user input).
#define RMPMARL_ASSERT(cond, message)                                          \
  do {                                                                         \
    if (!(cond)) ::rmpmarl::AbortInvariant(#cond, __FILE__, __LINE__, message); \
  } while (0)

/// Debug-only check for hot loops.
#ifdef NDEBUG
#define RMPMARL_DASSERT(cond, message) \
  do {                                 \
  } while (0)
#else
#define RMPMARL_DASSERT(cond, message) RMPMARL_ASSERT(cond, message)
#endif
