#include "run/alpha.h"

#include <atomic>
#include <filesystem>
#include <string>
#include <utility>

namespace afterimage {

bool fully_opaque(const ImageF& alpha, const Exec& ex) {
  std::atomic<bool> opaque{true};
  parallel_rows(ex, alpha.height(), [&](int y) {
    if (!opaque.load(std::memory_order_relaxed)) return;
    const float* a = alpha.row(0, y);
    for (int x = 0; x < alpha.width(); ++x)
      if (a[x] != 1.0f) {
        opaque.store(false, std::memory_order_relaxed);
        return;
      }
  });
  return opaque.load();
}

ImageF finite_alpha(ImageF alpha, const Exec& ex) {
  parallel_rows(ex, alpha.height(), [&](int y) {
    float* a = alpha.row(0, y);
    for (int x = 0; x < alpha.width(); ++x) a[x] = finite_alpha(a[x]);
  });
  return alpha;
}

ImageF alpha_as_color(const ImageF& alpha, const Exec& ex) {
  ImageF c = ImageF::uninitialized(alpha.width(), alpha.height(), 3);
  parallel_rows(ex, alpha.height(), [&](int y) {
    const float* a = alpha.row(0, y);
    for (int p = 0; p < 3; ++p) {
      float* d = c.row(p, y);
      for (int x = 0; x < alpha.width(); ++x) d[x] = finite_alpha(a[x]);
    }
  });
  return c;
}

ImageF alpha_of_color(const ImageF& color, const Exec& ex) {
  ImageF a = ImageF::uninitialized(color.width(), color.height(), 1);
  parallel_rows(ex, color.height(), [&](int y) {
    const float* s = color.row(0, y);
    std::copy(s, s + color.width(), a.row(0, y));
  });
  return a;
}

Frame alpha_frame(const Frame& f, ChannelSet uses, const Exec& ex) {
  Frame in = f.header_only();
  in.color =
      f.has(Channel::alpha) ? alpha_as_color(f.alpha, ex) : ImageF(f.width, f.height, 3, 1.0f);
  for (const ChannelInfo& c : kChannelTable) {
    if (c.key == Channel::color || c.key == Channel::alpha || !uses.contains(c.key) ||
        !f.has(c.key))
      continue;
    if (const ImageF* p = f.plane_set(c.key)) *in.plane_set(c.key) = *p;
    if (const ImageU32* p = f.plane_set_u32(c.key)) *in.plane_set_u32(c.key) = *p;
  }
  return in;
}

namespace {

class WithAlpha final : public SequenceMethod {
 public:
  WithAlpha(std::unique_ptr<SequenceMethod> method,
            std::function<std::unique_ptr<SequenceMethod>()> make_twin, const Exec& exec)
      : method_(std::move(method)), make_twin_(std::move(make_twin)), exec_(exec) {}

  std::string name() const override { return method_->name(); }
  ChannelSet required_channels() const override { return method_->required_channels(); }
  ChannelSet used_channels() const override {
    ChannelSet s = method_->used_channels();
    s.insert(Channel::alpha);
    return s;
  }
  std::pair<int, int> output_size(int w, int h) const override {
    return method_->output_size(w, h);
  }
  void check_header(const FrameHeader& h, const WarnFn& note) const override {
    method_->check_header(h, note);
  }
  Frame process(const Frame& frame) override {
    Frame out = method_->process(frame);
    if (!frame.has(Channel::alpha)) {
      active_ = false;
      return out;
    }
    if (fully_opaque(frame.alpha, exec_)) {
      active_ = false;
      out.alpha = ImageF(out.color.width(), out.color.height(), 1, 1.0f);
      return out;
    }
    if (!twin_) twin_ = make_twin();
    if (!active_) twin_->reset();  // its history is of an earlier stretch of alpha
    active_ = true;
    // The twin's frame: the alpha as its color, the G-buffer it reads copied (`frame` is not
    // ours to move from).
    const Frame in = alpha_frame(frame, twin_->used_channels(), exec_);
    out.alpha = alpha_of_color(twin_->process(in).color, exec_);
    return out;
  }
  void reset() override {
    method_->reset();
    active_ = false;
  }
  // The alpha's state beside the method's while the alpha is in use; a stale one from an
  // earlier save to the same path is removed, so that loading never revives it.
  void save_state(const std::string& path) const override {
    method_->save_state(path);
    const std::string a = alpha_path(path);
    if (active_) {
      twin_->save_state(a);
    } else {
      std::error_code ec;
      std::filesystem::remove(a, ec);
    }
  }
  // Changes nothing unless both files are valid (the twin is loaded first, into a new instance).
  void load_state(const std::string& path) override {
    const std::string a = alpha_path(path);
    std::error_code ec;
    std::unique_ptr<SequenceMethod> twin;
    if (std::filesystem::exists(a, ec)) {
      twin = make_twin();
      twin->load_state(a);
    }
    method_->load_state(path);
    active_ = twin != nullptr;
    if (twin) twin_ = std::move(twin);
  }
  std::string settings_json() const override { return method_->settings_json(); }
  std::string describe_settings() const override { return method_->describe_settings(); }
  void set_exec(const Exec& exec) override {
    exec_ = exec;
    method_->set_exec(exec);
    if (twin_) twin_->set_exec(exec);
  }
  PlaneTraffic last_traffic() const override { return method_->last_traffic(); }

 private:
  static std::string alpha_path(const std::string& path) { return path + ".alpha"; }
  std::unique_ptr<SequenceMethod> make_twin() const {
    std::unique_ptr<SequenceMethod> t = make_twin_();
    t->set_exec(exec_);
    return t;
  }

  std::unique_ptr<SequenceMethod> method_;
  std::function<std::unique_ptr<SequenceMethod>()> make_twin_;
  std::unique_ptr<SequenceMethod> twin_;  // made at the first frame whose alpha is below 1
  bool active_ = false;                   // twin_ holds the history of the current stretch
  Exec exec_;
};

}  // namespace

std::unique_ptr<SequenceMethod> carry_alpha(
    std::unique_ptr<SequenceMethod> method,
    std::function<std::unique_ptr<SequenceMethod>()> make_twin, const Exec& exec) {
  return std::make_unique<WithAlpha>(std::move(method), std::move(make_twin), exec);
}

}  // namespace afterimage
