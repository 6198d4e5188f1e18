// Small vector / matrix math shared by every module.
// Conventions (DESIGN.md §3): column vectors, clip = P * V * M * p, right-handed view space
// looking down -Z. Matrices are double precision so that reprojection through two
// view-projections stays well inside the 0.01 px motion-vector budget.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

namespace afterimage {

template <class T>
struct Vec2 {
  T x{}, y{};
  constexpr Vec2() = default;
  constexpr Vec2(T x_, T y_) : x(x_), y(y_) {}
  constexpr Vec2 operator+(Vec2 o) const { return {x + o.x, y + o.y}; }
  constexpr Vec2 operator-(Vec2 o) const { return {x - o.x, y - o.y}; }
  constexpr Vec2 operator*(T s) const { return {x * s, y * s}; }
  constexpr bool operator==(const Vec2&) const = default;
};

template <class T>
struct Vec3 {
  T x{}, y{}, z{};
  constexpr Vec3() = default;
  constexpr Vec3(T x_, T y_, T z_) : x(x_), y(y_), z(z_) {}
  constexpr explicit Vec3(T s) : x(s), y(s), z(s) {}
  constexpr T operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  constexpr T& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  constexpr Vec3 operator+(Vec3 o) const { return {x + o.x, y + o.y, z + o.z}; }
  constexpr Vec3 operator-(Vec3 o) const { return {x - o.x, y - o.y, z - o.z}; }
  constexpr Vec3 operator*(Vec3 o) const { return {x * o.x, y * o.y, z * o.z}; }
  constexpr Vec3 operator/(Vec3 o) const { return {x / o.x, y / o.y, z / o.z}; }
  constexpr Vec3 operator*(T s) const { return {x * s, y * s, z * s}; }
  constexpr Vec3 operator/(T s) const { return {x / s, y / s, z / s}; }
  constexpr Vec3 operator-() const { return {-x, -y, -z}; }
  constexpr Vec3& operator+=(Vec3 o) {
    x += o.x;
    y += o.y;
    z += o.z;
    return *this;
  }
  constexpr Vec3& operator-=(Vec3 o) {
    x -= o.x;
    y -= o.y;
    z -= o.z;
    return *this;
  }
  constexpr Vec3& operator*=(T s) {
    x *= s;
    y *= s;
    z *= s;
    return *this;
  }
  constexpr bool operator==(const Vec3&) const = default;
};

template <class T>
constexpr Vec3<T> operator*(T s, Vec3<T> v) {
  return v * s;
}

template <class T>
struct Vec4 {
  T x{}, y{}, z{}, w{};
  constexpr Vec4() = default;
  constexpr Vec4(T x_, T y_, T z_, T w_) : x(x_), y(y_), z(z_), w(w_) {}
  constexpr Vec4(Vec3<T> v, T w_) : x(v.x), y(v.y), z(v.z), w(w_) {}
  constexpr Vec3<T> xyz() const { return {x, y, z}; }
};

using Vec2f = Vec2<float>;
using Vec2d = Vec2<double>;
using Vec3f = Vec3<float>;
using Vec3d = Vec3<double>;
using Vec4d = Vec4<double>;

template <class T>
constexpr T dot(Vec3<T> a, Vec3<T> b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
template <class T>
constexpr Vec3<T> cross(Vec3<T> a, Vec3<T> b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <class T>
inline T length(Vec3<T> a) {
  return std::sqrt(dot(a, a));
}
template <class T>
inline Vec3<T> normalize(Vec3<T> a) {
  T l = length(a);
  return l > T(0) ? a / l : a;
}
template <class T>
constexpr Vec3<T> vmin(Vec3<T> a, Vec3<T> b) {
  return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)};
}
template <class T>
constexpr Vec3<T> vmax(Vec3<T> a, Vec3<T> b) {
  return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)};
}
template <class T>
constexpr Vec3<T> lerp(Vec3<T> a, Vec3<T> b, T t) {
  return a + (b - a) * t;
}
template <class T>
constexpr T lerp(T a, T b, T t) {
  return a + (b - a) * t;
}
template <class T>
inline Vec3<float> to_float(Vec3<T> v) {
  return {float(v.x), float(v.y), float(v.z)};
}
template <class T>
inline Vec3<double> to_double(Vec3<T> v) {
  return {double(v.x), double(v.y), double(v.z)};
}

// 4x4 matrix, m[row][col], acting on column vectors.
struct Mat4 {
  std::array<std::array<double, 4>, 4> m{};

  static constexpr Mat4 identity() {
    Mat4 r;
    for (int i = 0; i < 4; ++i) r.m[i][i] = 1.0;
    return r;
  }
  constexpr Mat4 operator*(const Mat4& o) const {
    Mat4 r;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) {
        double s = 0;
        for (int k = 0; k < 4; ++k) s += m[i][k] * o.m[k][j];
        r.m[i][j] = s;
      }
    return r;
  }
  constexpr Vec4d operator*(const Vec4d& v) const {
    return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z + m[0][3] * v.w,
            m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z + m[1][3] * v.w,
            m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z + m[2][3] * v.w,
            m[3][0] * v.x + m[3][1] * v.y + m[3][2] * v.z + m[3][3] * v.w};
  }
  // Affine point / direction transforms (ignore the projective row).
  constexpr Vec3d transform_point(Vec3d p) const { return (*this * Vec4d(p, 1.0)).xyz(); }
  constexpr Vec3d transform_dir(Vec3d d) const { return (*this * Vec4d(d, 0.0)).xyz(); }
  constexpr bool operator==(const Mat4&) const = default;

  Mat4 transposed() const;
  Mat4 inverse() const;  // general 4x4 inverse (cofactor expansion)
};

Mat4 translate(Vec3d t);
Mat4 scale(Vec3d s);
Mat4 rotate_axis(Vec3d axis, double radians);
// View matrix of a camera at `eye` looking at `target` (right-handed, looks down -Z).
Mat4 look_at(Vec3d eye, Vec3d target, Vec3d up);

// Unit quaternion for animation (slerp of rotations).
struct Quat {
  double w = 1, x = 0, y = 0, z = 0;
  static Quat from_axis_angle(Vec3d axis, double radians);
  static Quat from_matrix(const Mat4& rot);  // upper 3x3 must be a rotation
  Mat4 to_matrix() const;
};
Quat slerp(Quat a, Quat b, double t);

constexpr double kPi = 3.14159265358979323846;

}  // namespace afterimage
