// Image samplers in pixel coordinates: position (x, y) with pixel (i, j)'s center at
// (i + 0.5, j + 0.5) (DESIGN.md §3). All clamp to the edge. These scalar forms are the
// readable reference; SIMD kernels use the lane-templated N-plane gathers in
// reproject/gather.h, tested against these per plane.
#pragma once

#include <cmath>

#include "core/image.h"

namespace afterimage {

// Nearest pixel whose footprint contains (x, y) (HLSL Load / point sampling).
inline float sample_point(const PlaneView& img, float x, float y) {
  return img.at_clamped(int(std::floor(x)), int(std::floor(y)));
}

// Bilinear between the four nearest pixel centers.
inline float sample_bilinear(const PlaneView& img, float x, float y) {
  float tx = x - 0.5f, ty = y - 0.5f;
  float fx0 = std::floor(tx), fy0 = std::floor(ty);
  int x0 = int(fx0), y0 = int(fy0);
  float fx = tx - fx0, fy = ty - fy0;
  float a = img.at_clamped(x0, y0), b = img.at_clamped(x0 + 1, y0);
  float c = img.at_clamped(x0, y0 + 1), d = img.at_clamped(x0 + 1, y0 + 1);
  float top = a + (b - a) * fx, bot = c + (d - c) * fx;
  return top + (bot - top) * fy;
}

// Catmull-Rom cubic weights for the four taps at offsets -1, 0, 1, 2 around the fractional
// position f in [0, 1) (Keys cubic with a = -0.5; seed 003 writes it with c = 0.5).
struct CubicWeights {
  float w0, w1, w2, w3;
};
inline CubicWeights catmull_rom_weights(float f, float c = 0.5f) {
  float f2 = f * f, f3 = f2 * f;
  return {-c * f3 + 2.0f * c * f2 - c * f, (2.0f - c) * f3 - (3.0f - c) * f2 + 1.0f,
          -(2.0f - c) * f3 + (3.0f - 2.0f * c) * f2 + c * f, c * f3 - c * f2};
}

// Full 16-tap Catmull-Rom bicubic: the reference the cheaper approximations are judged by.
inline float sample_catmull_rom_16(const PlaneView& img, float x, float y) {
  float tx = x - 0.5f, ty = y - 0.5f;
  float fx0 = std::floor(tx), fy0 = std::floor(ty);
  int x0 = int(fx0), y0 = int(fy0);
  CubicWeights wx = catmull_rom_weights(tx - fx0), wy = catmull_rom_weights(ty - fy0);
  const float wxs[4] = {wx.w0, wx.w1, wx.w2, wx.w3};
  const float wys[4] = {wy.w0, wy.w1, wy.w2, wy.w3};
  float sum = 0.0f;
  for (int j = 0; j < 4; ++j) {
    float rowsum = 0.0f;
    for (int i = 0; i < 4; ++i) rowsum += wxs[i] * img.at_clamped(x0 - 1 + i, y0 - 1 + j);
    sum += wys[j] * rowsum;
  }
  return sum;
}

// Positions and weights of the bilinear taps that approximate Catmull-Rom: the middle two
// taps of each axis are merged into one bilinear fetch at tc12 (seed 003 / MJP).
struct CatmullRomTaps {
  float tc0x, tc12x, tc3x, tc0y, tc12y, tc3y;
  float w0x, w12x, w3x, w0y, w12y, w3y;
};
inline CatmullRomTaps catmull_rom_taps(float x, float y) {
  // tc1 = floor(p - 0.5) + 0.5 is the center of the pixel at or left of p.
  float tc1x = std::floor(x - 0.5f) + 0.5f, tc1y = std::floor(y - 0.5f) + 0.5f;
  CubicWeights wx = catmull_rom_weights(x - tc1x), wy = catmull_rom_weights(y - tc1y);
  CatmullRomTaps t;
  t.w0x = wx.w0;
  t.w12x = wx.w1 + wx.w2;
  t.w3x = wx.w3;
  t.w0y = wy.w0;
  t.w12y = wy.w1 + wy.w2;
  t.w3y = wy.w3;
  t.tc0x = tc1x - 1.0f;
  t.tc3x = tc1x + 2.0f;
  t.tc12x = tc1x + wx.w2 / t.w12x;
  t.tc0y = tc1y - 1.0f;
  t.tc3y = tc1y + 2.0f;
  t.tc12y = tc1y + wy.w2 / t.w12y;
  return t;
}

// 9 bilinear taps (3x3 of tc0 / tc12 / tc3): exact Catmull-Rom away from borders.
inline float sample_catmull_rom_9(const PlaneView& img, float x, float y) {
  CatmullRomTaps t = catmull_rom_taps(x, y);
  const float px[3] = {t.tc0x, t.tc12x, t.tc3x}, wx[3] = {t.w0x, t.w12x, t.w3x};
  const float py[3] = {t.tc0y, t.tc12y, t.tc3y}, wy[3] = {t.w0y, t.w12y, t.w3y};
  float sum = 0.0f;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) sum += wx[i] * wy[j] * sample_bilinear(img, px[i], py[j]);
  return sum;
}

// Activision's 5-tap Catmull-Rom (Filmic SMAA, SIGGRAPH 2016; seed 003 SampleHistoryBicubic):
// the 9-tap version without its four corner taps, renormalised by the remaining weights.
inline float sample_catmull_rom_5(const PlaneView& img, float x, float y) {
  CatmullRomTaps t = catmull_rom_taps(x, y);
  float cw0 = t.w12x * t.w0y, cw1 = t.w0x * t.w12y, cw2 = t.w12x * t.w12y;
  float cw3 = t.w3x * t.w12y, cw4 = t.w12x * t.w3y;
  float s =
      cw0 * sample_bilinear(img, t.tc12x, t.tc0y) + cw1 * sample_bilinear(img, t.tc0x, t.tc12y) +
      cw2 * sample_bilinear(img, t.tc12x, t.tc12y) + cw3 * sample_bilinear(img, t.tc3x, t.tc12y) +
      cw4 * sample_bilinear(img, t.tc12x, t.tc3y);
  return s / (cw0 + cw1 + cw2 + cw3 + cw4);
}

}  // namespace afterimage
