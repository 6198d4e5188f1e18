// A frame loop as a renderer would run it: each frame is "rendered" into the program's own
// buffers (jittered color, depth, motion), handed to TAA through BufferViews, and resolved
// into an output buffer the program owns. At the end the last raw frame and the last TAA
// output are scored against a supersampled reference; the program fails if TAA is not better.
//
// The scene: a rotated checkerboard on a plane at depth 10 (still) and a thin bright bar on a
// card at depth 5 moving right. Conventions (docs/DESIGN.md §3): pixel (0, 0) is the top-left,
// y down; jitter in pixels; motion = p_prev - p_curr in pixels; depth is linear view depth.
#include <afterimage/afterimage.hpp>

#include <cmath>
#include <cstdio>
#include <vector>

namespace {

constexpr int kWidth = 160, kHeight = 90;
constexpr int kFrames = 48;
constexpr float kBarSpeed = 0.35f;  // pixels per frame, to the right

// What the renderer sees at one point of the image.
struct Surface {
  float r, g, b;
  float depth;               // linear view depth
  float motion_x, motion_y;  // p_prev - p_curr, pixels
};

// The scene at image position (x, y) (pixels, continuous) in frame t.
Surface scene(double x, double y, int t) {
  // The bar: 1.2 px wide, 30 degrees from vertical, its centre line moving right.
  const double cx = 40.0 + kBarSpeed * t, cy = 45.0;
  const double nx = std::cos(0.5236), ny = -std::sin(0.5236);  // normal of the bar's line
  if (std::fabs((x - cx) * nx + (y - cy) * ny) < 0.6)
    return {6.0f, 4.0f, 1.5f, 5.0f, -kBarSpeed, 0.0f};  // HDR: values above 1 are normal
  // The checkerboard: 7 px squares rotated by 20 degrees, so every edge is aliased.
  const double c = std::cos(0.349), s = std::sin(0.349);
  const double u = (x * c + y * s) / 7.0, v = (-x * s + y * c) / 7.0;
  const bool dark = (int(std::floor(u)) + int(std::floor(v))) & 1;
  return dark ? Surface{0.05f, 0.06f, 0.08f, 10.0f, 0, 0} : Surface{0.8f, 0.7f, 0.6f, 10.0f, 0, 0};
}

// Radical inverse in `base`: the Halton sequence.
double halton(int index, int base) {
  double f = 1.0, r = 0.0;
  for (; index > 0; index /= base) {
    f /= base;
    r += f * (index % base);
  }
  return r;
}

// An OpenGL-style perspective projection, row-major (m[row * 4 + col]), unjittered.
void perspective(float vfov_deg, float aspect, float z_near, float z_far, float (&m)[16]) {
  const float t = 1.0f / std::tan(0.5f * vfov_deg * 3.14159265f / 180.0f);
  for (float& e : m) e = 0.0f;
  m[0] = t / aspect;
  m[5] = t;
  m[10] = -(z_far + z_near) / (z_far - z_near);
  m[11] = -2.0f * z_far * z_near / (z_far - z_near);
  m[14] = -1.0f;
}

}  // namespace

int main() {
  try {
    afterimage::Method taa("taa:afterimage");
    std::printf("afterimage %s (%s), method %s\n", afterimage::version(),
                afterimage::simd_target().c_str(), taa.name().c_str());

    // The renderer's buffers, reused every frame. Color is RGBA interleaved (16 bytes a pixel);
    // the library reads them through views and keeps nothing after process() returns.
    std::vector<float> color(size_t(kWidth) * kHeight * 4);
    std::vector<float> depth(size_t(kWidth) * kHeight);
    std::vector<float> motion(size_t(kWidth) * kHeight * 2);
    std::vector<float> resolved(size_t(kWidth) * kHeight * 3);  // TAA's output, RGB

    afterimage::FrameInput frame;
    frame.color = afterimage::BufferView::interleaved(color.data(), kWidth, kHeight, 4);
    frame.depth = afterimage::BufferView::interleaved(depth.data(), kWidth, kHeight, 1);
    frame.motion = afterimage::BufferView::interleaved(motion.data(), kWidth, kHeight, 2);
    const afterimage::BufferView out =
        afterimage::BufferView::interleaved(resolved.data(), kWidth, kHeight, 3);

    // A still camera: the identity view (FrameCamera's default), a 45 degree perspective.
    frame.camera.known = true;
    perspective(45.0f, float(kWidth) / kHeight, 0.1f, 100.0f, frame.camera.projection);

    for (int t = 0; t < kFrames; ++t) {
      // Halton(2, 3) over 16 phases, skipping index 0, centred on the pixel.
      const int k = t % 16 + 1;
      frame.camera.jitter_x = float(halton(k, 2) - 0.5);
      frame.camera.jitter_y = float(halton(k, 3) - 0.5);
      frame.camera.index = t;
      frame.camera.time = t / 60.0;

      // "Render": one sample per pixel at the jittered position, as a rasteriser would.
      for (int y = 0; y < kHeight; ++y)
        for (int x = 0; x < kWidth; ++x) {
          const Surface s =
              scene(x + 0.5 + frame.camera.jitter_x, y + 0.5 + frame.camera.jitter_y, t);
          const size_t i = size_t(y) * kWidth + x;
          color[4 * i + 0] = s.r;
          color[4 * i + 1] = s.g;
          color[4 * i + 2] = s.b;
          color[4 * i + 3] = 1.0f;  // opaque
          depth[i] = s.depth;
          // Frame 0 has no previous frame: its motion is zero and not used.
          motion[2 * i + 0] = t == 0 ? 0.0f : s.motion_x;
          motion[2 * i + 1] = t == 0 ? 0.0f : s.motion_y;
        }

      taa.process(frame, out);
    }

    // The reference for the last frame: 8 x 8 samples per pixel, a box filter.
    const int last = kFrames - 1, n = 8;
    std::vector<float> reference(size_t(kWidth) * kHeight * 3);
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x) {
        double sum[3] = {0, 0, 0};
        for (int sy = 0; sy < n; ++sy)
          for (int sx = 0; sx < n; ++sx) {
            const Surface s = scene(x + (sx + 0.5) / n, y + (sy + 0.5) / n, last);
            sum[0] += s.r;
            sum[1] += s.g;
            sum[2] += s.b;
          }
        for (int c = 0; c < 3; ++c)
          reference[(size_t(y) * kWidth + x) * 3 + c] = float(sum[c] / (n * n));
      }

    // PSNR on display values (HDR tonemapped, then sRGB). The raw frame's view has 4 channels:
    // the metrics read its RGB.
    const auto ref = afterimage::BufferView::interleaved(reference.data(), kWidth, kHeight, 3);
    const double raw_db = afterimage::psnr(ref, frame.color);
    const double taa_db = afterimage::psnr(ref, out);
    std::printf("frame %d: PSNR raw jittered %.2f dB, TAA %.2f dB\n", last, raw_db, taa_db);
    if (!(taa_db > raw_db)) {
      std::fprintf(stderr, "TAA did not improve on the raw frame\n");
      return 1;
    }
    return 0;
  } catch (const afterimage::Error& e) {
    // Every error of the library is one line naming what was wrong.
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
