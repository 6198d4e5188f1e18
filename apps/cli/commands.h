// Each subcommand of the `afterimage` CLI lives in its own cmd_*.cpp and only parses
// arguments and calls the library (DESIGN.md §6: thin CLI).
#pragma once

#include <CLI/CLI.hpp>

#include <string>

#include <fmt/format.h>

#include "core/error.h"
#include "core/parallel.h"
#include "io/sequence_input.h"
#include "run/sequence.h"

namespace afterimage::cli {

// Options shared by every subcommand (--threads, --simd).
struct Context {
  Exec exec = Exec::from_env();
  std::string command_line;  // argv joined, for reports
};

// --name, --layout, --map, --jitter, --jitter-file into `in` (cmd_resolve.cpp).
void add_sequence_input_options(CLI::App* sub, io::SequenceInput& in);
// --out-name: the output file name stem (default: each output keeps its input's file name).
void add_output_name_option(CLI::App* sub, std::string& out_name);
// Prints a library note (layout chosen, camera unknown, "warning: ..." for repaired input)
// as one "afterimage: ..." line on stderr.
void print_note(const std::string& note);

// What `resolve` and `denoise` share: the files, output format and state files of a
// files-to-files run of one registry method (their argument structs derive from it).
struct MethodRunOptions {
  SequenceFiles files;  // --in, --name, --layout, --map, --jitter*, --out
  std::string save_state, load_state;
  std::string out_format = "exr", tonemap = "reinhard";
  bool sequential = false;
};
// Checks --in / --out, loads the state, runs `method` files to files (run_sequence) with a
// progress line "VERB LABEL: frame k/n" on stderr, then saves the state (cmd_resolve.cpp).
SequenceRunStats run_method_files(SequenceMethod& method, const MethodRunOptions& o,
                                  const char* verb, const std::string& label);

// Parses "640x360" (--size) into width / height (both >= 1); throws SettingsError otherwise.
void parse_size(const std::string& text, int* width, int* height);

void add_render_command(CLI::App& app, Context& ctx);
void add_info_command(CLI::App& app, Context& ctx);
void add_compare_command(CLI::App& app, Context& ctx);
void add_eval_command(CLI::App& app, Context& ctx);
void add_resolve_command(CLI::App& app, Context& ctx);
void add_denoise_command(CLI::App& app, Context& ctx);
void add_demo_command(CLI::App& app, Context& ctx);
void add_bench_command(CLI::App& app, Context& ctx);
void add_run_command(CLI::App& app, Context& ctx);
void add_extrapolate_command(CLI::App& app, Context& ctx);

}  // namespace afterimage::cli
