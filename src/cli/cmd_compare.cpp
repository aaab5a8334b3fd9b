// lancer compare A B: how far apart two images are, whatever made them (any format OpenImageIO
// reads, PFM included). Exit status as cmp(1): 0 identical bits, 1 different, 2 bad input
// (unreadable file, sizes differ).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "lancer/compare.hpp"
#include "lancer/diff_map.hpp"
#include "lancer/error.hpp"
#include "lancer/image.hpp"
#include "lancer/text.hpp"

namespace lancer::cli {

namespace {
struct CompareArgs {
  std::string a, b;
  std::vector<std::string> thresholds{"1/255", "2/255"};
  std::string diff;
  double diff_scale = 0;  // 0: a false-colour log map (diff_map.hpp); else |a - b| x this
  bool as_displayed = false;
  bool json = false;
};

// "0.004" or "1/255": a threshold on a channel's absolute difference.
double parse_threshold(const std::string& text) {
  const auto slash = text.find('/');
  try {
    std::size_t used = 0;
    double v = std::stod(text.substr(0, slash), &used);
    if (used != text.substr(0, slash).size()) throw std::invalid_argument(text);
    if (slash != std::string::npos) {
      const std::string den = text.substr(slash + 1);
      const double d = std::stod(den, &used);
      if (used != den.size() || !(d > 0)) throw std::invalid_argument(text);
      v /= d;
    }
    if (!(v >= 0) || !std::isfinite(v)) throw std::invalid_argument(text);
    return v;
  } catch (const std::logic_error&) {
    throw InputError("--threshold: " + text + ": must be a number >= 0 or a fraction like 1/255");
  }
}

// JSON has no infinity: an identical pair's PSNR is written as null.
nlohmann::json finite_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nullptr; }

void run_compare(const CompareArgs& args, int& status) {
  std::vector<double> thresholds;
  for (const std::string& t : args.thresholds) thresholds.push_back(parse_threshold(t));
  if (!args.diff.empty()) {
    // Before check_output_path, whose "scene file" names what render protects, not an image.
    std::error_code ec;
    for (const std::string* input : {&args.a, &args.b})
      if (args.diff == *input || (std::filesystem::exists(args.diff, ec) &&
                                  std::filesystem::equivalent(args.diff, *input, ec)))
        throw InputError("--diff " + shown_path(args.diff) + ": would overwrite the " +
                         (input == &args.a ? "first" : "second") + " input image");
    check_output_path(args.diff, args.a);
  }
  if (args.diff_scale < 0 || !std::isfinite(args.diff_scale))
    throw InputError("--diff-scale: must be >= 0");
  const Image a = read_image(args.a);
  const Image b = read_image(args.b);
  if (a.nx != b.nx || a.ny != b.ny)
    throw InputError(args.a + " is " + std::to_string(a.nx) + "x" + std::to_string(a.ny) + ", " +
                     args.b + " is " + std::to_string(b.nx) + "x" + std::to_string(b.ny) +
                     ": sizes differ");
  const ImageComparison c = compare_images(a, b, thresholds, args.as_displayed);
  const double scale = args.diff_scale;
  DiffMap map;
  if (!args.diff.empty()) {
    if (scale > 0) {
      write_image(difference_image(a, b, scale), args.diff);
    } else {
      map = false_colour_difference(a, b);
      write_image(map.image, args.diff);
    }
  }

  const std::uint64_t pixels = std::uint64_t(a.nx) * std::uint64_t(a.ny);
  if (args.json) {
    nlohmann::json j{{"a", args.a},
                     {"b", args.b},
                     {"width", a.nx},
                     {"height", a.ny},
                     {"pixels", pixels},
                     {"identical", c.bits.identical()},
                     {"differing_pixels", c.bits.differing_pixels},
                     {"max_ulps", c.bits.max_ulps},
                     {"max_abs", finite_or_null(c.error.max_abs)},
                     {"psnr_db", finite_or_null(c.error.psnr_db)},
                     {"values", args.as_displayed ? "clamped to [0, 1]" : "as stored"}};
    if (!c.bits.identical()) j["first_differing_pixel"] = {c.bits.first_i, c.bits.first_j};
    nlohmann::json off = nlohmann::json::array();
    for (std::size_t k = 0; k < thresholds.size(); ++k)
      off.push_back({{"threshold", thresholds[k]},
                     {"threshold_text", args.thresholds[k]},
                     {"pixels", c.off_pixels[k]},
                     {"fraction", c.off_fractions[k]}});
    j["off"] = off;
    if (!args.diff.empty() && scale > 0)
      j["diff"] = {{"path", args.diff}, {"map", "linear"}, {"scale", scale}};
    else if (!args.diff.empty())
      j["diff"] = {{"path", args.diff},        {"map", "log"},
                   {"low", map.low},           {"high", map.high},
                   {"bar_rows", map.bar_rows}, {"coloured_pixels", map.coloured}};
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    std::printf("lancer compare: %s vs %s, %d x %d, values %s\n", args.a.c_str(), args.b.c_str(),
                a.nx, a.ny, args.as_displayed ? "clamped to [0, 1]" : "as stored");
    std::printf("  differing pixels  %llu of %llu (%.4g%%)\n",
                (unsigned long long)c.bits.differing_pixels, (unsigned long long)pixels,
                pixels ? 100.0 * double(c.bits.differing_pixels) / double(pixels) : 0.0);
    if (!c.bits.identical())
      std::printf("  first differing   (%d, %d)\n", c.bits.first_i, c.bits.first_j);
    std::printf("  max ulps          %llu\n", (unsigned long long)c.bits.max_ulps);
    std::printf("  max abs diff      %.6g\n", c.error.max_abs);
    if (std::isfinite(c.error.psnr_db))
      std::printf("  PSNR              %.2f dB (peak 1)\n", c.error.psnr_db);
    else
      std::printf("  PSNR              inf (identical values)\n");
    for (std::size_t k = 0; k < thresholds.size(); ++k)
      std::printf("  off by > %-8s %llu pixels (%.4g%%)\n", args.thresholds[k].c_str(),
                  (unsigned long long)c.off_pixels[k], 100.0 * c.off_fractions[k]);
    if (!args.diff.empty() && scale > 0)
      std::printf("  difference image  %s (|a - b| x %.6g)\n", args.diff.c_str(), scale);
    else if (!args.diff.empty() && map.coloured == 0)
      std::printf("  difference image  %s (black: no pixel differs)\n", args.diff.c_str());
    else if (!args.diff.empty())
      std::printf(
          "  difference image  %s: each pixel's largest |a - b| on a log scale, blue %.3g to "
          "yellow %.3g (the colour bar in the %d rows below the image), black identical, white "
          "NaN against a number; %llu pixels coloured\n",
          args.diff.c_str(), map.low, map.high, map.bar_rows, (unsigned long long)map.coloured);
    std::printf("%s\n", c.bits.identical() ? "identical" : "DIFFERENT");
  }
  status = c.bits.identical() ? 0 : 1;
}
}  // namespace

void add_compare(CLI::App& app) {
  auto args = std::make_shared<CompareArgs>();
  CLI::App* cmd = app.add_subcommand(
      "compare",
      "Compare two images of the same size (exit 0 iff bit-identical, 1 if not, 2 on bad input)");
  cmd->add_option("a", args->a, "First image (any format OpenImageIO reads, or PFM)")->required();
  cmd->add_option("b", args->b, "Second image, the reference for PSNR")->required();
  cmd->add_option("--threshold", args->thresholds,
                  "Count pixels with a channel off by more than each, e.g. 1/255,0.01")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--diff", args->diff,
                  "Write the differences to this image: each pixel's largest |a - b| in false "
                  "colour on a log scale, with a colour bar below (or see --diff-scale)");
  cmd->add_option("--diff-scale", args->diff_scale,
                  "Write |a - b| per channel times this instead, the inputs' size, linear");
  cmd->add_flag("--as-displayed", args->as_displayed,
                "Clamp values to [0, 1] first, as an 8-bit file would show them");
  cmd->add_flag("--json", args->json, "Print one JSON object");
  cmd->callback([args] {
    int status = 0;
    run_compare(*args, status);
    if (status != 0) std::exit(status);
  });
}

}  // namespace lancer::cli
