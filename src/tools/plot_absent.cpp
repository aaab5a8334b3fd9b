// The figures without cairo (-DLANCER_WITH_PLOTS=OFF, e.g. the aarch64 cross build, which does
// not install cairo's arm64 packages): every figure is refused with one line saying why, before
// any file is written.
#include <string>
#include <vector>

#include "lancer/error.hpp"
#include "lancer/plot.hpp"

namespace lancer::plot {

namespace {
[[noreturn]] void refuse(const std::string& what) {
  throw InputError(what +
                   ": this lancer was built without cairo (LANCER_WITH_PLOTS=OFF), so it "
                   "draws no figures");
}
}  // namespace

std::vector<LabelBox> label_boxes(const Chart&) { refuse("label boxes"); }

void write_chart(const Chart&, const std::string& path) { refuse(path); }

}  // namespace lancer::plot
