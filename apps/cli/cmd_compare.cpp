#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "apps/cli/commands.h"
#include "core/error.h"
#include "io/io.h"
#include "metrics/metrics.h"

namespace afterimage::cli {

namespace {

struct CompareArgs {
  std::string reference, test;
  bool json = false;
  float ppd = metrics::flip_default_ppd();
};

// As the official FLIP tool: the reference file's type decides. EXR / HDR hold linear
// radiance (HDR-FLIP, tonemapped display metrics); anything else is sRGB-encoded LDR.
metrics::DynamicRange range_of(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext == ".exr" || ext == ".hdr" ? metrics::DynamicRange::kHdr : metrics::DynamicRange::kLdr;
}

void run_compare(const CompareArgs& a, const Context& ctx) {
  const ImageF ref = io::read_rgb(a.reference);
  const ImageF test = io::read_rgb(a.test);
  metrics::require_finite(ref, a.reference);  // the same rule as eval
  metrics::require_finite(test, a.test);
  if (ref.width() != test.width() || ref.height() != test.height())
    throw InputError(fmt::format("{}: size {}x{} differs from the reference {} ({}x{})", a.test,
                                 test.width(), test.height(), a.reference, ref.width(),
                                 ref.height()));
  metrics::MetricsSettings s;
  s.flip.ppd = a.ppd;
  const auto m = metrics::compare_images(ref, test, range_of(a.reference), s, ctx.exec);
  if (a.json) {
    nlohmann::json j = m;
    j["reference"] = a.reference;
    j["test"] = a.test;
    fmt::print("{}\n", j.dump(2));
  } else {
    fmt::print("reference            {}\ntest                 {}\n{}", a.reference, a.test,
               metrics::format_pair_metrics(m));
  }
}

}  // namespace

void add_compare_command(CLI::App& app, Context& ctx) {
  auto* sub = app.add_subcommand(
      "compare", "PSNR, SSIM and FLIP of a test image against a reference (EXR: HDR, PNG: LDR)");
  auto args = std::make_shared<CompareArgs>();
  sub->add_option("REFERENCE", args->reference, "reference image (its type picks LDR/HDR)")
      ->required();
  sub->add_option("TEST", args->test, "image to evaluate")->required();
  sub->add_flag("--json", args->json, "print JSON (infinite PSNR as \"inf\")");
  sub->add_option("--ppd", args->ppd, "FLIP viewing condition, pixels per degree")
      ->check(CLI::PositiveNumber);
  sub->callback([args, &ctx] { run_compare(*args, ctx); });
}

}  // namespace afterimage::cli
