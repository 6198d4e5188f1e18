// Lane helpers shared by the tests of lane-templated kernels (core/lanes.h, reproject/,
// taa_kernels.h): tags, building colors from scalars and reading lanes back.
#pragma once

#include <gtest/gtest.h>

#include <vector>

#include "core/lanes.h"
#include "core/math.h"
#include "core/simd.h"

namespace afterimage::test {

inline const FullTag kFull;
inline const OneTag kOne;

template <class D>
Color3<D> set3(D d, Vec3f c) {
  return splat(d, c.x, c.y, c.z);
}
template <class D>
std::vector<float> lanes(D d, V<D> v) {
  std::vector<float> r(hn::Lanes(d));
  hn::StoreU(v, d, r.data());
  return r;
}
template <class D>
std::vector<Vec3f> lanes_of(D d, const Color3<D>& c) {
  const std::vector<float> a = lanes(d, c.c0), b = lanes(d, c.c1), e = lanes(d, c.c2);
  std::vector<Vec3f> r(a.size());
  for (size_t i = 0; i < a.size(); ++i) r[i] = {a[i], b[i], e[i]};
  return r;
}
template <class D>
Vec3f lane0(D, const Color3<D>& c) {
  return {hn::GetLane(c.c0), hn::GetLane(c.c1), hn::GetLane(c.c2)};
}
template <class D>
float lane0(D, V<D> v) {
  return hn::GetLane(v);
}
inline void expect_near3(Vec3f a, Vec3f b, float tol) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

}  // namespace afterimage::test
