// libFuzzer target for the CSV reader of `lancer plot`: lancer::plot::chart_from_csv, what
// `plot` does with the file's bytes once the bounded reader has them.
//
// The property under test: for ANY byte string, chart_from_csv either returns a chart whose
// series each hold as many x values as y values, all finite, or throws lancer::InputError whose
// message is one non-empty line naming the file. Any other exception, crash, hang or sanitizer
// report is a finding.
//
// Build and run with .ci/fuzz.sh; every finding becomes a case in test_regressions.cpp.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "lancer/error.hpp"
#include "lancer/plot.hpp"

namespace {

[[noreturn]] void finding(const std::string& what, const std::string& input) {
  std::fprintf(stderr, "\nlancer fuzz finding: %s\ninput (%zu bytes):\n%s\n", what.c_str(),
               input.size(), input.c_str());
  std::abort();  // libFuzzer saves the input as a crash artifact
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string name = "fuzz.csv";
  // Columns the seeds have: x and y always, the group only when the input is long enough to be
  // worth it (both ways taken).
  const std::string group = size % 2 ? "engine" : "";
  try {
    const lancer::plot::Chart c =
        lancer::plot::chart_from_csv(text, name, "x", "y", group, lancer::plot::Mark::line_points);
    for (const lancer::plot::Series& s : c.series) {
      if (s.x.size() != s.y.size()) finding("a series with unequal x and y counts", text);
      for (std::size_t k = 0; k < s.x.size(); ++k)
        if (!std::isfinite(s.x[k]) || !std::isfinite(s.y[k]))
          finding("a non-finite value in a chart", text);
    }
  } catch (const lancer::InputError& e) {
    const std::string m = e.what();
    if (m.empty() || m.find('\n') != std::string::npos)
      finding("message is empty or not one line: " + m, text);
    if (m.compare(0, name.size(), name) != 0) finding("message does not name the file: " + m, text);
  } catch (const std::exception& e) {
    finding(std::string("chart_from_csv threw a non-InputError exception: ") + e.what(), text);
  } catch (...) {
    finding("chart_from_csv threw a non-std exception", text);
  }
  return 0;
}
