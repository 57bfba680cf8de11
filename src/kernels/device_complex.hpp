#pragma once
// DeviceComplex: a plain complex double for target regions (two doubles, the layout of fftw_complex and
// cufftDoubleComplex, so spectra are reinterpreted in place). std::complex is avoided inside target regions: its
// general product may call libgcc's __muldc3, which the nvptx offload libraries need not provide. Only the operations
// the per-mode solve uses; each is the textbook formula, so results equal std::complex's for finite values.
#include "kernels/device_macros.hpp"

namespace capsflow {

CAPSFLOW_DEVICE_BEGIN
struct DeviceComplex {
  double re, im;
  DeviceComplex() = default;
  constexpr explicit DeviceComplex(double r, double i = 0.0) : re(r), im(i) {}
  DeviceComplex& operator+=(const DeviceComplex& o) {
    re += o.re;
    im += o.im;
    return *this;
  }
  DeviceComplex& operator*=(double s) {
    re *= s;
    im *= s;
    return *this;
  }
};

inline DeviceComplex operator+(const DeviceComplex& a, const DeviceComplex& b) {
  return DeviceComplex(a.re + b.re, a.im + b.im);
}
inline DeviceComplex operator-(const DeviceComplex& a, const DeviceComplex& b) {
  return DeviceComplex(a.re - b.re, a.im - b.im);
}
inline DeviceComplex operator-(const DeviceComplex& a) { return DeviceComplex(-a.re, -a.im); }
inline DeviceComplex operator*(const DeviceComplex& a, double s) { return DeviceComplex(a.re * s, a.im * s); }
inline DeviceComplex operator*(double s, const DeviceComplex& a) { return DeviceComplex(s * a.re, s * a.im); }
inline DeviceComplex operator/(const DeviceComplex& a, double s) { return DeviceComplex(a.re / s, a.im / s); }
inline DeviceComplex operator*(const DeviceComplex& a, const DeviceComplex& b) {
  return DeviceComplex(a.re * b.re - a.im * b.im, a.re * b.im + a.im * b.re);
}
CAPSFLOW_DEVICE_END

}  // namespace capsflow
