// Small fixed-size geometry in double precision: 3-vectors, 3x3 and 4x4
// matrices (row-major, column vectors: p_world = M * p_local), quaternions
// (w, x, y, z). Everything is header-only and constexpr-friendly enough for
// hot loops; no allocation.
#ifndef POINTFORWARD_COMMON_GEOMETRY_H_
#define POINTFORWARD_COMMON_GEOMETRY_H_

#include <algorithm>
#include <array>
#include <cmath>

namespace pf {

struct Vec3 {
  double x = 0, y = 0, z = 0;
  double& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  double operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
};

inline Vec3 operator+(const Vec3& a, const Vec3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(const Vec3& a, const Vec3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator-(const Vec3& a) { return {-a.x, -a.y, -a.z}; }
inline Vec3 operator*(double s, const Vec3& a) { return {s * a.x, s * a.y, s * a.z}; }
inline Vec3 operator*(const Vec3& a, double s) { return s * a; }
inline Vec3 operator/(const Vec3& a, double s) { return {a.x / s, a.y / s, a.z / s}; }
inline double Dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 Cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double Norm(const Vec3& a) { return std::sqrt(Dot(a, a)); }
inline Vec3 Normalized(const Vec3& a) {
  const double n = Norm(a);
  return n > 0 ? a / n : a;
}

// 3x3 matrix, row-major: m[r][c].
struct Mat3 {
  std::array<std::array<double, 3>, 3> m{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  static Mat3 Identity() { return Mat3{}; }
  // Returns the matrix whose columns are `c0`, `c1`, `c2` (e.g. the axes of a
  // frame, giving world_from_frame).
  static Mat3 FromColumns(const Vec3& c0, const Vec3& c1, const Vec3& c2) {
    Mat3 r;
    r.m = {{{c0.x, c1.x, c2.x}, {c0.y, c1.y, c2.y}, {c0.z, c1.z, c2.z}}};
    return r;
  }
  Vec3 Row(int r) const { return {m[r][0], m[r][1], m[r][2]}; }
  Vec3 Col(int c) const { return {m[0][c], m[1][c], m[2][c]}; }
};

inline Vec3 operator*(const Mat3& a, const Vec3& v) {
  return {Dot(a.Row(0), v), Dot(a.Row(1), v), Dot(a.Row(2), v)};
}
inline Mat3 operator*(const Mat3& a, const Mat3& b) {
  Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      r.m[i][j] = a.m[i][0] * b.m[0][j] + a.m[i][1] * b.m[1][j] + a.m[i][2] * b.m[2][j];
  return r;
}
inline Mat3 Transpose(const Mat3& a) {
  Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[j][i];
  return r;
}
inline double Determinant(const Mat3& a) { return Dot(a.Row(0), Cross(a.Row(1), a.Row(2))); }

inline constexpr double kDegreesPerRadian = 180 / M_PI;

// Returns the rotation by `radians` about z (counter-clockwise seen from +z).
inline Mat3 RotationZ(double radians) {
  const double c = std::cos(radians), s = std::sin(radians);
  Mat3 r;
  r.m = {{{c, -s, 0}, {s, c, 0}, {0, 0, 1}}};
  return r;
}

// Returns the rotation by |w| radians about w / |w| (Rodrigues' formula);
// the identity for w = 0.
inline Mat3 RotationFromVector(const Vec3& w) {
  const double angle = Norm(w);
  Mat3 r;
  if (angle == 0) return r;
  const Vec3 k = w / angle;
  const double c = std::cos(angle), s = std::sin(angle), v = 1 - c;
  r.m = {{{c + v * k.x * k.x, v * k.x * k.y - s * k.z, v * k.x * k.z + s * k.y},
          {v * k.y * k.x + s * k.z, c + v * k.y * k.y, v * k.y * k.z - s * k.x},
          {v * k.z * k.x - s * k.y, v * k.z * k.y + s * k.x, c + v * k.z * k.z}}};
  return r;
}

// Unit quaternion (w, x, y, z) for rotations; Hamilton convention, so
// ToMatrix(q) * v rotates v by q.
struct Quat {
  double w = 1, x = 0, y = 0, z = 0;
};

inline double QuatNorm(const Quat& q) {
  return std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
}
inline Quat QuatNormalized(const Quat& q) {
  const double n = QuatNorm(q);
  return n > 0 ? Quat{q.w / n, q.x / n, q.y / n, q.z / n} : Quat{};
}
inline Quat operator*(const Quat& a, const Quat& b) {
  return {
      a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z, a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
      a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x, a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w};
}

// Returns the rotation matrix of `q` (normalised first).
inline Mat3 ToMatrix(const Quat& q_in) {
  const Quat q = QuatNormalized(q_in);
  const double w = q.w, x = q.x, y = q.y, z = q.z;
  Mat3 r;
  r.m = {{{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
          {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
          {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}}};
  return r;
}

// Returns the unit quaternion of rotation matrix `r` (w >= 0).
inline Quat FromMatrix(const Mat3& r) {
  const auto& m = r.m;
  const double trace = m[0][0] + m[1][1] + m[2][2];
  Quat q;
  if (trace > 0) {
    const double s = 0.5 / std::sqrt(trace + 1.0);
    q = {0.25 / s, (m[2][1] - m[1][2]) * s, (m[0][2] - m[2][0]) * s, (m[1][0] - m[0][1]) * s};
  } else if (m[0][0] > m[1][1] && m[0][0] > m[2][2]) {
    const double s = 2.0 * std::sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]);
    q = {(m[2][1] - m[1][2]) / s, 0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s};
  } else if (m[1][1] > m[2][2]) {
    const double s = 2.0 * std::sqrt(1.0 + m[1][1] - m[0][0] - m[2][2]);
    q = {(m[0][2] - m[2][0]) / s, (m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s};
  } else {
    const double s = 2.0 * std::sqrt(1.0 + m[2][2] - m[0][0] - m[1][1]);
    q = {(m[1][0] - m[0][1]) / s, (m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s};
  }
  if (q.w < 0) q = {-q.w, -q.x, -q.y, -q.z};
  return QuatNormalized(q);
}

// Spherical linear interpolation from `a` (s = 0) to `b` (s = 1), along the
// shorter arc.
inline Quat Slerp(const Quat& a_in, const Quat& b_in, double s) {
  const Quat a = QuatNormalized(a_in);
  Quat b = QuatNormalized(b_in);
  double cos_theta = a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z;
  if (cos_theta < 0) {
    b = {-b.w, -b.x, -b.y, -b.z};
    cos_theta = -cos_theta;
  }
  double wa, wb;
  if (cos_theta > 0.9995) {
    wa = 1 - s;
    wb = s;
  } else {
    const double theta = std::acos(cos_theta);
    const double sin_theta = std::sin(theta);
    wa = std::sin((1 - s) * theta) / sin_theta;
    wb = std::sin(s * theta) / sin_theta;
  }
  return QuatNormalized(
      {wa * a.w + wb * b.w, wa * a.x + wb * b.x, wa * a.y + wb * b.y, wa * a.z + wb * b.z});
}

// A rigid transform: p' = rotation * p + translation.
struct Rigid {
  Mat3 rotation;
  Vec3 translation;

  Vec3 operator*(const Vec3& p) const { return rotation * p + translation; }
  Rigid operator*(const Rigid& o) const {
    return {rotation * o.rotation, rotation * o.translation + translation};
  }
  Rigid Inverse() const {
    const Mat3 rt = Transpose(rotation);
    return {rt, -(rt * translation)};
  }
  // Returns the 16 numbers of the 4x4 matrix, row-major.
  std::array<double, 16> ToRowMajor() const {
    const auto& r = rotation.m;
    const Vec3& t = translation;
    return {r[0][0], r[0][1], r[0][2], t.x, r[1][0], r[1][1], r[1][2], t.y,
            r[2][0], r[2][1], r[2][2], t.z, 0,       0,       0,       1};
  }
  // Builds from 16 row-major numbers; the last row is not checked (see
  // RigidityError).
  static Rigid FromRowMajor(const double* v) {
    Rigid t;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) t.rotation.m[r][c] = v[4 * r + c];
      t.translation[r] = v[4 * r + 3];
    }
    return t;
  }
};

// The pose a fraction `s` of the way from `a` (s = 0) to `b` (s = 1): the
// translation linearly, the rotation by slerp.
inline Rigid InterpolateRigid(const Rigid& a, const Rigid& b, double s) {
  Rigid out;
  out.rotation = ToMatrix(Slerp(FromMatrix(a.rotation), FromMatrix(b.rotation), s));
  out.translation = a.translation + s * (b.translation - a.translation);
  return out;
}

// How far 16 row-major numbers are from a rigid transform: the largest of
// |R^T R - I| entries, |det R - 1| and |last row - (0, 0, 0, 1)|. Also returns
// det R through `determinant` if given.
inline double RigidityError(const double* v, double* determinant = nullptr) {
  const Rigid t = Rigid::FromRowMajor(v);
  const Mat3 rtr = Transpose(t.rotation) * t.rotation;
  double err = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) err = std::max(err, std::abs(rtr.m[i][j] - (i == j ? 1.0 : 0.0)));
  const double det = Determinant(t.rotation);
  if (determinant != nullptr) *determinant = det;
  err = std::max(err, std::abs(det - 1.0));
  err = std::max({err, std::abs(v[12]), std::abs(v[13]), std::abs(v[14]), std::abs(v[15] - 1.0)});
  return err;
}

}  // namespace pf

#endif  // POINTFORWARD_COMMON_GEOMETRY_H_
