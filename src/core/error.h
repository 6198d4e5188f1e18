// Two tiers of errors (DESIGN.md §6):
//  * AI_CHECK(a op b): invariants of our own code; prints both operands and aborts.
//  * afterimage::Error (and subclasses): user / input / I/O problems, thrown and caught once
//    at the CLI or Python boundary, where they become one line and a non-zero exit code.
#pragma once

#include <fmt/format.h>

#include <cstdio>
#include <cstdlib>
#include <functional>
#include <stdexcept>
#include <string>

#include "afterimage/errors.hpp"

namespace afterimage {

// Error, InputError, SettingsError and OutputError (user / input / I/O problems, `what()` one
// line) are the public API's (include/afterimage/errors.hpp), so that a program using the
// library catches what the modules throw.

// Receives one-line warnings ("<file>: <what was found and what was done>"): input that was
// repaired rather than refused. The CLI prints them to stderr; an empty function drops them.
using WarnFn = std::function<void(const std::string&)>;

[[noreturn]] inline void check_failed(const char* file, int line, const std::string& msg) {
  std::fprintf(stderr, "%s:%d: CHECK failed: %s\n", file, line, msg.c_str());
  std::abort();
}

}  // namespace afterimage

#define AI_CHECK(cond)                                                  \
  do {                                                                  \
    if (!(cond)) ::afterimage::check_failed(__FILE__, __LINE__, #cond); \
  } while (0)

#define AI_CHECK_OP(a, op, b)                                                                    \
  do {                                                                                           \
    const auto& ai_a_ = (a);                                                                     \
    const auto& ai_b_ = (b);                                                                     \
    if (!(ai_a_ op ai_b_))                                                                       \
      ::afterimage::check_failed(__FILE__, __LINE__,                                             \
                                 fmt::format("{} {} {} ({} vs {})", #a, #op, #b, ai_a_, ai_b_)); \
  } while (0)
#define AI_CHECK_EQ(a, b) AI_CHECK_OP(a, ==, b)
#define AI_CHECK_LT(a, b) AI_CHECK_OP(a, <, b)
#define AI_CHECK_LE(a, b) AI_CHECK_OP(a, <=, b)
#define AI_CHECK_GT(a, b) AI_CHECK_OP(a, >, b)
#define AI_CHECK_GE(a, b) AI_CHECK_OP(a, >=, b)

#ifdef NDEBUG
#define AI_DCHECK(cond) ((void)0)
#else
#define AI_DCHECK(cond) AI_CHECK(cond)
#endif
