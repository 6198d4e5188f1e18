// Self-contained HTML report (DESIGN.md §4): a results table, per-frame plots as inline SVG,
// zoomed crops side by side and error maps as embedded PNG, and the exact command lines.
// No network access is needed to view it.
#pragma once

#include <limits>
#include <map>
#include <string>
#include <vector>

#include "core/image.h"

namespace afterimage {

// One method's results on one scene.
struct MethodSummary {
  std::string label;
  std::map<std::string, double> aggregate;               // metric -> value (after warm-up)
  std::map<std::string, std::vector<double>> per_frame;  // metric -> value per frame
  std::vector<double> ghosting;                          // error k = 1..8 frames after disocclusion
  double ms_per_frame = -1;                              // < 0: not measured
  std::string command;                                   // how the output was produced
};

// A panel of a side-by-side comparison: a display-encoded RGB image (values in [0, 1]).
struct Panel {
  std::string caption;
  ImageF image;
};
struct Figure {
  std::string title;
  std::vector<Panel> panels;
};

struct SceneSection {
  std::string name;
  std::string description;
  std::vector<MethodSummary> methods;
  std::vector<Figure> figures;  // crops at the worst regions, error maps
};

struct ReportData {
  std::string title = "Afterimage evaluation";
  std::vector<std::string> commands;  // exact command lines that produced the data
  std::vector<std::string> notes;
  std::vector<SceneSection> scenes;
};

// Metric column order and formatting of the results table.
struct MetricColumn {
  std::string key, header;
  bool higher_is_better;
  double target = std::numeric_limits<double>::quiet_NaN();  // if set: best = closest to it
  // True if value a is better than value b in this column.
  bool better(double a, double b) const;
};
const std::vector<MetricColumn>& report_columns();

std::string render_report_html(const ReportData& data);

// Base64 (RFC 4648) for embedding PNG bytes in data: URIs.
std::string base64_encode(const std::vector<unsigned char>& bytes);

// A simple inline-SVG line plot of several named series over frames.
std::string svg_line_plot(const std::string& title,
                          const std::vector<std::pair<std::string, std::vector<double>>>& series,
                          const std::string& x_label = "frame", int first_x = 0);

}  // namespace afterimage
