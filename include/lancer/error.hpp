// The three error channels of lancer (after pbrt-v4):
//  - InputError: the user's input is wrong (scene file, option, output path). Its message is one
//    line that names the place; the CLI prints it and exits with status 2.
//  - LANCER_CHECK: an internal invariant; prints the failing values and aborts.
//  - kernels are noexcept and report through the masks they return.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <stdexcept>
#include <string>

#include "lancer/export.hpp"

namespace lancer {

struct LANCER_API InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

namespace detail {
[[noreturn]] inline void check_failed(const char* expr, const char* file, int line,
                                      const std::string& values) {
  std::fprintf(stderr, "lancer: internal check failed at %s:%d: %s%s%s\n", file, line, expr,
               values.empty() ? "" : " with ", values.c_str());
  std::abort();
}
template <class A, class B>
std::string show_pair(const A& a, const B& b) {
  std::ostringstream s;
  s << a << " vs " << b;
  return s.str();
}
}  // namespace detail

}  // namespace lancer

#define LANCER_CHECK(cond) \
  ((cond) ? (void)0 : ::lancer::detail::check_failed(#cond, __FILE__, __LINE__, ""))
// Checks a relation between two values and prints both when it fails.
#define LANCER_CHECK_OP(a, op, b)                                                     \
  (((a)op(b)) ? (void)0                                                               \
              : ::lancer::detail::check_failed(#a " " #op " " #b, __FILE__, __LINE__, \
                                               ::lancer::detail::show_pair((a), (b))))
