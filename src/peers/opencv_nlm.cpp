#include "peers/opencv_nlm.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/photo.hpp>

#include "core/color.h"
#include "core/error.h"

namespace afterimage::peers {

const ParamTable<NlmSettings>& NlmSettings::params() {
  static const ParamTable<NlmSettings> kTable = [] {  // immutable once built
    using S = NlmSettings;
    ParamTable<S> t("nlm");
    t.add_float("h", &S::h, 0.1f, 100.0f, "luminance filter strength (8-bit units)");
    t.add_float("h_color", &S::h_color, 0.1f, 100.0f, "chroma filter strength (8-bit units)");
    t.add_int("window", &S::window, 1, 15, "temporal window in frames (odd)");
    t.add_int("template_size", &S::template_size, 3, 15, "patch size in pixels (odd)");
    t.add_int("search_size", &S::search_size, 3, 51, "search window in pixels (odd)");
    t.add_float("exposure", &S::exposure, 1e-6f, 1e6f, "exposure before the display transform");
    t.check([](const S& s) {
      for (auto [name, v] : {std::pair{"window", s.window},
                             {"template_size", s.template_size},
                             {"search_size", s.search_size}})
        if (v % 2 == 0) return fmt::format("{} {} must be odd", name, v);
      return std::string();
    });
    return t;
  }();
  return kTable;
}

unsigned char display_code(float linear, float exposure) {
  const float v = std::isfinite(linear) ? srgb_encode(tonemap_reinhard(linear, exposure)) : 0.0f;
  return static_cast<unsigned char>(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f));
}

float linear_from_code(float code, float exposure) {
  const float y = srgb_decode(std::min(code, 254.5f) / 255.0f);  // Reinhard value in [0, 1)
  return y / (1.0f - y) / exposure;
}

int nlm_window_at(size_t k, size_t n, int window) {
  const size_t side = std::min({size_t(window / 2), k, n - 1 - k});
  return int(2 * side + 1);
}

ImageF opencv_nlm_frame(const std::vector<ImageF>& noisy, size_t k, const NlmSettings& s,
                        const Exec& ex) {
  s.validate();
  if (noisy.empty() || k >= noisy.size())
    throw InputError(fmt::format("nlm: frame {} of a sequence of {}", k, noisy.size()));
  const int w = noisy[k].width(), h = noisy[k].height();
  const int tws = nlm_window_at(k, noisy.size(), s.window);
  const size_t first = k - size_t(tws / 2);
  std::vector<cv::Mat> frames;
  for (size_t i = first; i < first + size_t(tws); ++i) {
    const ImageF& img = noisy[i];
    if (img.width() != w || img.height() != h || img.channels() != 3)
      throw InputError(fmt::format("nlm: frame {} is {}x{}x{}, frame {} {}x{}x3", i, img.width(),
                                   img.height(), img.channels(), k, w, h));
    cv::Mat m(h, w, CV_8UC3);
    for (int y = 0; y < h; ++y) {
      unsigned char* row = m.ptr<unsigned char>(y);
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c)  // OpenCV's order is BGR: its luma / chroma split needs it
          row[3 * x + (2 - c)] = display_code(img.at(x, y, c), s.exposure);
    }
    frames.push_back(std::move(m));
  }
  cv::setNumThreads(ex.threads > 0 ? ex.threads : -1);
  cv::Mat out;
  cv::fastNlMeansDenoisingColoredMulti(frames, out, tws / 2, tws, s.h, s.h_color, s.template_size,
                                       s.search_size);
  ImageF result = ImageF::uninitialized(w, h, 3);
  for (int y = 0; y < h; ++y) {
    const unsigned char* row = out.ptr<unsigned char>(y);
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c)
        result.at(x, y, c) = linear_from_code(float(row[3 * x + (2 - c)]), s.exposure);
  }
  return result;
}

}  // namespace afterimage::peers
