// Helpers shared by the library API's tests.
#pragma once

#include <functional>
#include <string>

#include "lancer/lancer.hpp"

namespace lancer::testing {

// Options pinned to a precision and width, on one thread.
inline api::Options with(Precision p, int width = 0) {
  api::Options o;
  o.precision = p;
  o.width = width;
  o.threads = 1;
  return o;
}

// The message of the InputError `fn` throws, or "(no error)".
inline std::string error_of(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace lancer::testing
