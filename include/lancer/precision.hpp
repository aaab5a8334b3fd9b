#pragma once

#include <string>

#include "lancer/export.hpp"

namespace lancer {

// exact: IEEE float, bit-identical at every width. dbl: IEEE double (the gold standard).
// fast: float with FMA and refined approximate reciprocal / reciprocal square root, packets only.
// automatic: exact where the scene lies inside float's measured envelope, double elsewhere.
enum class Precision { exact, dbl, fast, automatic };

LANCER_API const char* to_string(Precision p);
// Parses exact / double / fast / auto; throws InputError naming `option`.
LANCER_API Precision parse_precision(const std::string& text, const std::string& option);

}  // namespace lancer
