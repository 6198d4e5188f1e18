#include "run/post_pipeline.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <utility>

#include "core/error.h"
#include "core/sanitize.h"
#include "post/bloom.h"
#include "post/dof.h"
#include "post/flare.h"
#include "post/motion_blur.h"
#include "post/sharpen.h"
#include "post/tonemap.h"
#include "run/alpha.h"
#include "run/methods.h"

namespace afterimage {

namespace {

// One stage's block of a --list-settings listing: a header naming the stage, then the table's
// lines ("key = value default D, range R -- doc") indented.
std::string settings_block(const std::string& stage, const std::string& lines) {
  std::string out = stage + ":\n";
  size_t start = 0;
  while (start < lines.size()) {
    const size_t end = std::min(lines.find('\n', start), lines.size());
    out += "  " + lines.substr(start, end - start) + "\n";
    start = end + 1;
  }
  return out;
}

// A post stage over a settings struct S with a parameter table and a pure pass, of the color
// alone (Pass) or of the color with the frame's G-buffer (FramePass).
template <class S>
class TableStage : public PostStage {
 public:
  using Pass = ImageF (*)(const ImageF&, const S&, const Exec&);
  using FramePass = ImageF (*)(const Frame&, const ImageF&, const S&, const Exec&);
  explicit TableStage(Pass pass) : pass_(pass) {}
  TableStage(FramePass pass, ChannelSet needs) : frame_pass_(pass), needs_(needs) {}
  ChannelSet required_channels() const override { return needs_; }
  void set(const std::string& assignment) override { S::params().set_assignment(s_, assignment); }
  void validate() const override { S::params().validate(s_); }
  ImageF apply(const Frame& frame, const ImageF& color, const Exec& ex) const override {
    return frame_pass_ ? frame_pass_(frame, color, s_, ex) : pass_(color, s_, ex);
  }
  std::string settings_json() const override { return S::params().to_json(s_); }
  std::string describe_settings() const override { return S::params().describe(s_, defaults_); }
  S& settings() { return s_; }
  const S& settings() const { return s_; }

 protected:
  // The current settings become the stage's defaults in its listing (a stage whose defaults
  // differ from its struct's).
  void keep_as_defaults() { defaults_ = s_; }

 private:
  Pass pass_ = nullptr;
  FramePass frame_pass_ = nullptr;
  ChannelSet needs_;
  S s_;
  S defaults_;
};

// dof checks each frame's lens before the run writes anything (post::checked_dof_lens).
class DofStage : public TableStage<post::DofSettings> {
 public:
  DofStage() : TableStage(&post::depth_of_field, ChannelSet{Channel::depth}) {}
  bool filters_alpha() const override { return true; }
  void check_header(const FrameHeader& h, const WarnFn& note) const override {
    post::checked_dof_lens(h, settings(), note);
  }
};

// motion_blur remembers the previous frame's camera (camera/object split) and its trail
// window across process() calls (post::MotionBlurSequence).
class MotionBlurStage : public TableStage<post::MotionBlurSettings> {
 public:
  MotionBlurStage() : TableStage(&post::motion_blur, ChannelSet{Channel::depth, Channel::motion}) {}
  bool filters_alpha() const override { return true; }
  ImageF process(const Frame& frame, const ImageF& color, const Exec& ex) override {
    return sequence_.process(frame, color, settings(), ex);
  }
  void reset() override { sequence_.reset(); }
  bool keeps_frames() const override { return post::keeps_frames(settings()); }
  void check_header(const FrameHeader& h, const WarnFn&) const override {
    post::check_motion_blur_camera(h, settings());
  }

 private:
  post::MotionBlurSequence sequence_;
};

// bloom can run the stages after it (flare's light, tonemap) on each row it composites.
class BloomStage : public TableStage<post::BloomSettings> {
 public:
  BloomStage() : TableStage(static_cast<Pass>(&post::bloom)) {}
  bool fuses_row_pass() const override { return true; }
  using PostStage::process;
  ImageF process(const Frame&, const ImageF& color, const Exec& ex,
                 const post::RowPass& then) override {
    return post::bloom(color, settings(), ex, then);
  }
  ImageF process_owned(const Frame&, ImageF& color, const Exec& ex,
                       const post::RowPass& then) override {
    return post::bloom(std::move(color), settings(), ex, then);
  }
};

// flare adds its light to each row bloom composites (lens_flare_row_pass of bloom's input), or
// runs the stage after it on each row it composites (lens_flare's RowPass).
class FlareStage : public TableStage<post::FlareSettings> {
 public:
  FlareStage() : TableStage(static_cast<Pass>(&post::lens_flare)) {}
  bool fuses_row_pass() const override { return true; }
  post::RowPass row_pass(const Exec& ex, const ImageF& radiance) const override {
    return post::lens_flare_row_pass(radiance, settings(), ex);
  }
  using PostStage::process;
  ImageF process(const Frame&, const ImageF& color, const Exec& ex,
                 const post::RowPass& then) override {
    return post::lens_flare(color, settings(), ex, then);
  }
  ImageF process_owned(const Frame&, ImageF& color, const Exec& ex,
                       const post::RowPass& then) override {
    return post::lens_flare(std::move(color), settings(), ex, then);
  }
};

// tonemap is per pixel: it runs as the stage before it finishes each row where that stage can.
class TonemapStage : public TableStage<post::TonemapSettings> {
 public:
  TonemapStage() : TableStage(&post::tonemap) {}
  post::RowPass row_pass(const Exec& ex, const ImageF&) const override {
    return post::tonemap_row_pass(settings(), ex);
  }
};

// sharpen is the chain's last pass, on the tonemapped image (the "available last"; the
// DESIGN.md chain ends tonemap -> sharpen): a Laplacian on display values, where a highlight's
// radiance no longer outweighs its neighbours by orders of magnitude. Listed, it sharpens with
// seed 000 Eq.5's filter as written (strength 1, Uncharted 4's c + 4c - up - down - left -
// right), clamped to the 3x3 range as post/sharpen does; the method option `+sharpen=S` keeps
// its default 0.
class SharpenStage : public TableStage<post::SharpenSettings> {
 public:
  SharpenStage() : TableStage(&post::sharpen) {
    settings().sharpen = 1.0f;
    keep_as_defaults();
  }
};

class PipelineMethod : public SequenceMethod {
 public:
  // `temporal_listing`: the temporal methods' settings blocks (settings_block), made while
  // they were separate (a denoiser + resolve chain is one method here). `alpha_post`: the
  // twins of the stages that filter alpha (PostStage::filters_alpha), in chain order.
  PipelineMethod(std::string name, std::unique_ptr<SequenceMethod> temporal,
                 std::string temporal_listing,
                 std::vector<std::pair<std::string, std::unique_ptr<PostStage>>> post,
                 std::vector<std::unique_ptr<PostStage>> alpha_post, const Exec& exec)
      : name_(std::move(name)),
        temporal_(std::move(temporal)),
        temporal_listing_(std::move(temporal_listing)),
        post_(std::move(post)),
        alpha_post_(std::move(alpha_post)),
        exec_(exec) {}

  std::string name() const override { return name_; }
  ChannelSet required_channels() const override {
    return with_stages(temporal_ ? temporal_->required_channels() : ChannelSet{Channel::color});
  }
  ChannelSet used_channels() const override {
    ChannelSet s = with_stages(temporal_ ? temporal_->used_channels() : ChannelSet{Channel::color});
    s.insert(Channel::alpha);
    return s;
  }
  std::pair<int, int> output_size(int w, int h) const override {
    return temporal_ ? temporal_->output_size(w, h) : std::pair(w, h);
  }
  void check_header(const FrameHeader& h, const WarnFn& note) const override {
    if (temporal_) temporal_->check_header(h, note);
    for (const auto& [name, stage] : post_) stage->check_header(h, note);
  }
  Frame process(const Frame& frame) override {
    Frame out;
    ImageF alpha;  // the alpha entering the post stages (the temporal method's, or the frame's)
    if (temporal_) {
      out = temporal_->process(frame);
      alpha = std::move(out.alpha);
    } else {
      // A library caller's non-finite alpha reads as empty, as its color is sanitised below.
      if (frame.has(Channel::alpha)) alpha = finite_alpha(frame.alpha, exec_);
      // The reader warns that non-finite color is replaced by its neighbourhood's mean before
      // use: a temporal method does that (taa/resolver.h step 1); without one the chain does
      // it here (core/sanitize.h, which also sets negative values to 0), so no NaN or Inf
      // reaches a stage, an output file or motion blur's trail.
      out = frame.header_only();
      out.color =
          sanitize_color(frame.color, sanitized_, invalid_, exec_) ? sanitized_ : frame.color;
    }
    std::vector<PostStage*> stages;
    bool reads_gbuffer = false;
    for (const auto& [name, stage] : post_) {
      stages.push_back(stage.get());
      reads_gbuffer = reads_gbuffer || !stage->required_channels().empty();
    }
    // After an upscaler the stages that read depth or motion take them at the color's size.
    const int w = out.color.width(), h = out.color.height();
    Frame resized;
    if (reads_gbuffer && (w != frame.width || h != frame.height))
      resized = gbuffer_at_size(frame, w, h, exec_);
    const Frame& gbuffer = resized.width > 0 ? resized : frame;
    out.color = run_post_stages(stages, gbuffer, std::move(out.color), exec_);
    if (!alpha.empty()) out.alpha = post_alpha(gbuffer, std::move(alpha));
    return out;
  }
  void reset() override {
    if (temporal_) temporal_->reset();
    for (const auto& [name, stage] : post_) stage->reset();
    for (const auto& stage : alpha_post_) stage->reset();
  }
  void save_state(const std::string& path) const override {
    refuse_post_state();
    if (!temporal_) throw SettingsError("run: no temporal stage in the pipeline, so no state");
    temporal_->save_state(path);
  }
  void load_state(const std::string& path) override {
    refuse_post_state();
    if (!temporal_) throw SettingsError("run: no temporal stage in the pipeline, so no state");
    temporal_->load_state(path);
  }
  std::string settings_json() const override {
    nlohmann::json j;
    if (temporal_) j["temporal"] = nlohmann::json::parse(temporal_->settings_json());
    for (const auto& [name, stage] : post_) j[name] = nlohmann::json::parse(stage->settings_json());
    return j.dump();
  }
  std::string describe_settings() const override {
    std::string s = temporal_listing_;
    for (const auto& [name, stage] : post_) s += settings_block(name, stage->describe_settings());
    return s;
  }
  void set_exec(const Exec& exec) override {
    exec_ = exec;
    if (temporal_) temporal_->set_exec(exec);
  }

 private:
  // Post stages that keep frames have no state file format: refuse rather than continue with
  // a silently empty history.
  void refuse_post_state() const {
    for (const auto& [name, stage] : post_)
      if (stage->keeps_frames())
        throw SettingsError(fmt::format(
            "run: post stage '{}' keeps earlier frames with these settings (motion_blur camera "
            "split or trail); its state cannot be saved or loaded",
            name));
  }
  // The alpha through the twins of the stages that filter it. An opaque alpha stays 1 without
  // them where they keep no frames (a twin that does, motion_blur's camera split or trail,
  // always runs, so that its earlier frames are the color's).
  ImageF post_alpha(const Frame& gbuffer, ImageF alpha) {
    std::vector<PostStage*> twins;
    bool keeps = false;
    for (const auto& t : alpha_post_) {
      twins.push_back(t.get());
      keeps = keeps || t->keeps_frames();
    }
    if (twins.empty() || (!keeps && fully_opaque(alpha, exec_))) return alpha;
    const ImageF c = run_post_stages(twins, gbuffer, alpha_as_color(alpha, exec_), exec_);
    return alpha_of_color(c, exec_);
  }
  ChannelSet with_stages(ChannelSet set) const {
    for (const auto& [name, stage] : post_)
      for (const ChannelInfo& c : kChannelTable)
        if (stage->required_channels().contains(c.key)) set.insert(c.key);
    return set;
  }
  std::string name_;
  std::unique_ptr<SequenceMethod> temporal_;
  std::string temporal_listing_;
  ImageF sanitized_, invalid_;  // the repaired color of a frame that needed it (no temporal)
  std::vector<std::pair<std::string, std::unique_ptr<PostStage>>> post_;
  std::vector<std::unique_ptr<PostStage>> alpha_post_;
  Exec exec_;
};

// Two temporal methods in a row (`svgf,taa`): the second reads the first one's color with the
// input frame's G-buffer. State: the first method's at the path, the second's at path +
// ".resolve".
class TemporalChain final : public SequenceMethod {
 public:
  TemporalChain(std::unique_ptr<SequenceMethod> first, std::unique_ptr<SequenceMethod> second)
      : first_(std::move(first)), second_(std::move(second)) {}
  std::string name() const override { return first_->name() + "," + second_->name(); }
  ChannelSet required_channels() const override {
    return merged(first_->required_channels(), second_->required_channels());
  }
  ChannelSet used_channels() const override {
    return merged(first_->used_channels(), second_->used_channels());
  }
  std::pair<int, int> output_size(int w, int h) const override {
    const auto [w1, h1] = first_->output_size(w, h);
    return second_->output_size(w1, h1);
  }
  Frame process(const Frame& frame) override {
    Frame in = frame.header_only();
    Frame first = first_->process(frame);
    in.color = std::move(first.color);
    // A channel the first method produced and the second uses is taken from the first's output
    // (SVGF's temporal_change for TAA); the rest of the second method's G-buffer from the input
    // frame (copied: `frame` is not ours).
    const ChannelSet second_uses = second_->used_channels();
    for (const ChannelInfo& c : kChannelTable) {
      if (c.key == Channel::color || !second_uses.contains(c.key)) continue;
      if (first.has(c.key)) {
        if (ImageF* p = first.plane_set(c.key)) *in.plane_set(c.key) = std::move(*p);
        if (ImageU32* p = first.plane_set_u32(c.key)) *in.plane_set_u32(c.key) = std::move(*p);
        continue;
      }
      if (!frame.has(c.key)) continue;
      if (const ImageF* p = frame.plane_set(c.key)) *in.plane_set(c.key) = *p;
      if (const ImageU32* p = frame.plane_set_u32(c.key)) *in.plane_set_u32(c.key) = *p;
    }
    return second_->process(in);
  }
  void reset() override {
    first_->reset();
    second_->reset();
  }
  void save_state(const std::string& path) const override {
    first_->save_state(path);
    second_->save_state(path + ".resolve");
  }
  void load_state(const std::string& path) override {
    first_->load_state(path);
    second_->load_state(path + ".resolve");
  }
  std::string settings_json() const override {
    nlohmann::json j;
    j[first_->name()] = nlohmann::json::parse(first_->settings_json());
    j[second_->name()] = nlohmann::json::parse(second_->settings_json());
    return j.dump();
  }
  std::string describe_settings() const override {
    return first_->describe_settings() + second_->describe_settings();
  }
  void set_exec(const Exec& exec) override {
    first_->set_exec(exec);
    second_->set_exec(exec);
  }

 private:
  static ChannelSet merged(ChannelSet a, ChannelSet b) {
    for (const ChannelInfo& c : kChannelTable)
      if (b.contains(c.key)) a.insert(c.key);
    return a;
  }
  std::unique_ptr<SequenceMethod> first_, second_;
};

const PostStageInfo* find_stage(const std::string& name) {
  for (const auto& s : post_stages())
    if (s.name == name) return &s;
  return nullptr;
}

std::string stage_names() {
  std::vector<std::string> v;
  for (const MethodFamily& f : method_families()) v.push_back(f.technique + "[:variant]");
  for (const auto& s : post_stages()) v.push_back(s.name);
  return fmt::format("{}", fmt::join(v, ", "));
}

}  // namespace

namespace {
// stages[i] on `in`, with the stages after it that run row by row fused into it where it can
// run them (their frames are never written out and read back: post.chain 1080p, 7be56e8 and
// 80c79fa, docs/perf/2026-log.md); i moves past every stage it ran. own: `in` is the chain's own
// frame, which the stage may write its output over.
ImageF run_stage(const std::vector<PostStage*>& stages, size_t& i, const Frame& frame,
                 const ImageF& in, ImageF* own, const Exec& ex) {
  // Their RowPasses are made from the fusing stage's input, the radiance flare reads.
  post::RowPass then;
  size_t next = i + 1;
  if (stages[i]->fuses_row_pass())
    for (; next < stages.size(); ++next) {
      post::RowPass p = stages[next]->row_pass(ex, in);
      if (!p) break;
      then = post::row_pass_then(std::move(then), std::move(p));
    }
  PostStage& stage = *stages[i];
  i = next;
  return own ? stage.process_owned(frame, *own, ex, then) : stage.process(frame, in, ex, then);
}
}  // namespace

ImageF run_post_stages(const std::vector<PostStage*>& stages, const Frame& frame,
                       const ImageF& color, const Exec& ex) {
  if (stages.empty()) return color;  // a copy
  size_t i = 0;
  ImageF c = run_stage(stages, i, frame, color, nullptr, ex);  // reads the caller's image
  while (i < stages.size()) c = run_stage(stages, i, frame, c, &c, ex);
  return c;
}

ImageF run_post_stages(const std::vector<PostStage*>& stages, const Frame& frame, ImageF&& color,
                       const Exec& ex) {
  ImageF c = std::move(color);
  for (size_t i = 0; i < stages.size();) c = run_stage(stages, i, frame, c, &c, ex);
  return c;
}

Frame gbuffer_at_size(const Frame& in, int width, int height, const Exec& ex) {
  Frame out = in.header_only();
  out.width = width;
  out.height = height;
  const double sx = double(width) / in.width, sy = double(height) / in.height;
  out.jitter = {in.jitter.x * sx, in.jitter.y * sy};
  // The input pixel under output pixel x's centre: floor((x + 0.5) in.width / width).
  std::vector<int> col(static_cast<size_t>(width)), row(static_cast<size_t>(height));
  for (int x = 0; x < width; ++x)
    col[size_t(x)] = std::min(in.width - 1, int((x + 0.5) * in.width / width));
  for (int y = 0; y < height; ++y)
    row[size_t(y)] = std::min(in.height - 1, int((y + 0.5) * in.height / height));
  const auto resample = [&](const ImageF& src, ImageF& dst, const float(&scale)[2]) {
    dst = ImageF::uninitialized(width, height, src.channels());
    parallel_rows(ex, height, [&](int y) {  // a copy: the same values on any thread count
      for (int c = 0; c < src.channels(); ++c) {
        const float* s = src.row(c, row[size_t(y)]);
        float* d = dst.row(c, y);
        for (int x = 0; x < width; ++x) d[x] = s[col[size_t(x)]] * scale[c % 2];
      }
    });
  };
  if (in.has_depth()) resample(in.depth, out.depth, {1.0f, 1.0f});
  if (in.has_motion()) resample(in.motion, out.motion, {float(sx), float(sy)});
  return out;
}

Tonemap display_transform(const PipelineSpec& spec) {
  const auto has = [&](const char* name) {
    return std::find(spec.post.begin(), spec.post.end(), name) != spec.post.end();
  };
  if (!has("tonemap")) return Tonemap::reinhard;
  // The tonemap's srgb after the assignments: off, the file holds its values as they are (a
  // user who asked for linear display values gets them, not an sRGB curve from the writer).
  post::TonemapSettings t;
  for (const std::string& kv : spec.assignments)
    if (kv.rfind("tonemap.", 0) == 0) t.set_assignment(kv.substr(8));
  return has("sharpen") || !t.srgb ? Tonemap::encoded : Tonemap::clamp;
}

const std::vector<PostStageInfo>& post_stages() {
  // Immutable once built, so one shared copy is not state.
  static const std::vector<PostStageInfo> kStages{
      {"dof", 10,
       "depth of field from the frame's thin lens: scatter-as-gather over the signed circle of "
       "confusion with near / far field depth order, or mode=diffusion (Kass et al. 2006; "
       "post/dof.h)",
       [] { return std::make_unique<DofStage>(); }},
      {"motion_blur", 20,
       "McGuire 2012 reconstruction filter from the motion vectors: tile max, neighbour max, "
       "cone / cylinder weights with soft depth; optional camera / object clamps, no camera "
       "rotation, running-sum trail (post/motion_blur.h)",
       [] { return std::make_unique<MotionBlurStage>(); }},
      {"bloom", 30,
       "energy-conserving mip-chain bloom (13-tap down, 3x3 tent up; optional soft-knee "
       "bright pass and Karis average; post/bloom.h)",
       [] { return std::make_unique<BloomStage>(); }},
      {"flare", 40,
       "lens flare from the frame's bright lights: King's sprites, Chapman's ghosts and halo, "
       "streaks; optional Spencer et al. 1995 glare (post/flare.h)",
       [] { return std::make_unique<FlareStage>(); }},
      {"tonemap", 60,
       "exposure, tonemap operator (aces_fitted, agx, reinhard, ...) and sRGB encoding "
       "(post/tonemap.h)",
       [] { return std::make_unique<TonemapStage>(); }},
      {"sharpen", 70,
       "Laplacian sharpen of the tonemapped image (seed 000 Eq.5; sharpen=1 by default, clamped "
       "to the 3x3 range; post/sharpen.h)",
       [] { return std::make_unique<SharpenStage>(); }},
  };
  return kStages;
}

PipelineSpec parse_pipeline(const std::string& stages, const std::vector<std::string>& sets) {
  PipelineSpec spec;
  std::vector<std::string> names;
  size_t start = 0;
  while (start <= stages.size()) {
    const size_t comma = std::min(stages.find(',', start), stages.size());
    const std::string token = stages.substr(start, comma - start);
    start = comma + 1;
    if (token.empty()) continue;
    const std::string head = token.substr(0, token.find_first_of(":+"));
    if (find_stage(token)) {
      if (std::find(spec.post.begin(), spec.post.end(), token) != spec.post.end())
        throw SettingsError(fmt::format("--pipeline: stage '{}' listed twice", token));
      spec.post.push_back(token);
      names.push_back(token);
      continue;
    }
    const auto& fams = method_families();
    const auto fam = std::find_if(fams.begin(), fams.end(),
                                  [&](const MethodFamily& f) { return f.technique == head; });
    if (fam == fams.end())
      throw SettingsError(
          fmt::format("--pipeline: unknown stage '{}' (valid: {})", token, stage_names()));
    // One resolve stage (taa, taau) and at most one denoiser (svgf), which runs before it.
    std::string& slot = fam->denoiser ? spec.denoise : spec.temporal;
    if (!slot.empty())
      throw SettingsError(
          fmt::format("--pipeline: two temporal stages ('{}' and '{}')", slot, token));
    slot = token.find(':') == std::string::npos ? token + ":" + default_variant(head) : token;
    names.push_back(head);
  }
  if (spec.temporal.empty() && spec.denoise.empty() && spec.post.empty())
    throw SettingsError(fmt::format("--pipeline: no stage given (valid: {})", stage_names()));
  std::sort(spec.post.begin(), spec.post.end(), [](const std::string& a, const std::string& b) {
    return find_stage(a)->order < find_stage(b)->order;
  });
  for (const std::string& kv : sets) {
    const size_t dot = kv.find('.'), eq = kv.find('=');
    if (dot == std::string::npos || eq == std::string::npos || dot > eq)
      throw SettingsError(fmt::format("--set '{}': expected stage.key=value", kv));
    const std::string stage = kv.substr(0, dot);
    if (std::find(names.begin(), names.end(), stage) == names.end())
      throw SettingsError(fmt::format("--set '{}': stage '{}' is not in the pipeline ({})", kv,
                                      stage, fmt::join(names, ",")));
    spec.assignments.push_back(kv);
  }
  return spec;
}

std::string widest_pipeline() {
  std::vector<std::string> v;
  const auto& fams = method_families();
  for (const bool denoiser : {true, false}) {
    const auto f = std::find_if(fams.begin(), fams.end(),
                                [&](const MethodFamily& m) { return m.denoiser == denoiser; });
    if (f != fams.end()) v.push_back(f->technique);
  }
  for (const auto& s : post_stages()) v.push_back(s.name);
  return fmt::format("{}", fmt::join(v, ","));
}

std::unique_ptr<SequenceMethod> make_pipeline_method(const PipelineSpec& spec, const Exec& exec,
                                                     bool display_output) {
  std::unique_ptr<SequenceMethod> temporal;
  std::string name, temporal_listing;
  for (const std::string* method : {&spec.denoise, &spec.temporal}) {
    if (method->empty()) continue;
    // A temporal stage's assignments are overrides of its method spec.
    std::string t = *method;
    const std::string head = t.substr(0, t.find(':'));
    for (const auto& kv : spec.assignments)
      if (kv.compare(0, head.size() + 1, head + ".") == 0)
        t.append("+").append(kv, head.size() + 1);
    std::unique_ptr<SequenceMethod> m = make_method(t, exec);
    temporal_listing += settings_block(m->name(), m->describe_settings());
    // Denoiser, then resolve: one temporal method to the chain.
    temporal = temporal ? std::make_unique<TemporalChain>(std::move(temporal), std::move(m))
                        : std::move(m);
    name += (name.empty() ? "" : ",") + t;
  }
  std::vector<std::pair<std::string, std::unique_ptr<PostStage>>> post;
  std::vector<std::unique_ptr<PostStage>> alpha_post;
  for (const std::string& s : spec.post) {
    const auto configured = [&] {
      std::unique_ptr<PostStage> stage = find_stage(s)->make();
      for (const auto& kv : spec.assignments)
        if (kv.compare(0, s.size() + 1, s + ".") == 0) stage->set(kv.substr(s.size() + 1));
      return stage;
    };
    std::unique_ptr<PostStage> stage = configured();
    if (stage->filters_alpha()) alpha_post.push_back(configured());
    // 8-bit output: sRGB is encoded once. By the writer (the tonemap stage's srgb off), or,
    // when a sharpen stage follows, by the tonemap, so that it sharpens the values an EXR run
    // sharpens; an explicit tonemap.srgb=false stands, and nothing encodes (display_transform).
    if (display_output && s == "tonemap" && display_transform(spec) == Tonemap::clamp)
      stage->set("srgb=false");
    stage->validate();
    name += (name.empty() ? "" : ",") + s;
    post.emplace_back(s, std::move(stage));
  }
  return std::make_unique<PipelineMethod>("pipeline " + name, std::move(temporal),
                                          std::move(temporal_listing), std::move(post),
                                          std::move(alpha_post), exec);
}

}  // namespace afterimage
