// The registry of sequence methods (DESIGN.md §2): every temporal technique is reachable by
// name, "<technique>:<variant>[+key=value...]", e.g. "taa:hdrp" or
// "taa:afterimage+alpha_min=0.1". Commands, the demo and the bench list, validate and build
// methods only through here; adding a technique is one entry in methods.cpp.
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/parallel.h"
#include "frame/sequence_method.h"

namespace afterimage {

struct MethodFamily {
  std::string technique;              // "taa"
  std::string label;                  // in tables and reports: "TAA" -> "TAA hdrp"
  std::string command;                // the CLI that runs a variant: "afterimage resolve --preset"
  std::string description;            // one line for --help
  std::vector<std::string> variants;  // named presets, default first
  std::vector<std::string> demo_variants;  // what `demo` runs by default
  // `afterimage bench`: pass name prefix ("taa.resolve" -> "taa.resolve.hdrp") and the float
  // planes one frame must at least read and write (the bandwidth floor).
  std::string bench_pass;
  int bench_read_planes = 0, bench_write_planes = 0;
  // Input size of a bench row whose output is width x height (null: the same size; upsampling
  // methods read smaller frames).
  std::pair<int, int> (*bench_input_size)(const std::string& variant, int width, int height);
  // Markdown table of every setting (key, default, range, doc) for --list-settings --markdown.
  std::string (*settings_markdown)();
  // Builds variant + overrides (already split off the spec); throws SettingsError.
  std::unique_ptr<SequenceMethod> (*make)(const std::string& label, const std::string& variant,
                                          const std::vector<std::string>& overrides,
                                          const Exec& exec);
  // A denoiser (svgf): in a pipeline it runs before the resolve stage (taa or taau), whose input
  // is its output (`run --pipeline svgf,taa`).
  bool denoiser = false;
  // Variants with overrides that `bench` times beside the named ones (options that cost
  // bandwidth, e.g. "afterimage+confidence=false").
  std::vector<std::string> bench_extra_variants = {};
};

// A parsed "technique:variant+key=value+..." spec.
struct MethodSpec {
  std::string technique, variant;
  std::vector<std::string> overrides;  // "key=value"
};
// A bare "hdrp" means the first technique's variant ("taa:hdrp"). Throws SettingsError for an
// unknown technique (variants and keys are checked by make_method).
MethodSpec parse_method_spec(const std::string& spec);
// "TAA hdrp+alpha=0.2" (tables, reports) and "afterimage resolve --preset hdrp --set alpha=0.2".
std::string method_label(const std::string& spec);
std::string method_command(const std::string& spec);

// Every technique, in a stable order.
const std::vector<MethodFamily>& method_families();

// Parses "taa:hdrp+alpha=0.2" (a bare "hdrp" means "taa:hdrp", the technique of the
// first family) and builds the method. Throws SettingsError naming the spec and the valid
// names for unknown techniques, variants or keys, and for out-of-range values.
std::unique_ptr<SequenceMethod> make_method(const std::string& spec, const Exec& exec = {});

// "taa:afterimage", ... : every named variant of every technique.
std::vector<std::string> registered_method_names();
// The methods `demo` runs when none are given.
std::vector<std::string> default_demo_methods();
// The named variants of one technique ("taa" -> presets), default first; SettingsError if the
// technique is unknown.
const std::vector<std::string>& method_variants(const std::string& technique);
std::string default_variant(const std::string& technique);
// The TAAU method spec of a `resolve --upscale` argument: a TAAU preset (quality, balanced,
// performance), a scale per axis in [1, 4] or an output size WxH. SettingsError otherwise.
std::string upscale_method_spec(const std::string& arg);
// The technique's settings table as markdown (README tables come from here).
std::string settings_markdown(const std::string& technique);

}  // namespace afterimage
