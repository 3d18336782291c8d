#include "base/random.hpp"

#include <array>

namespace ambler::base {

namespace {

// Ziggurat tables for the standard normal: 128 layers of equal area V, base strip to R
// (Marsaglia & Tsang 2000; the layout of Doornik 2005, "An improved ziggurat method").
constexpr int kLayers = 128;
constexpr double kR = 3.442619855899;
constexpr double kV = 9.91256303526217e-3;

struct Ziggurat {
  std::array<double, kLayers + 1> x{};  // layer edges, x[0] = V / f(R) (the base strip's width)
  std::array<double, kLayers> ratio{};  // x[i+1] / x[i]: the part of layer i inside the curve
  Ziggurat() {
    double f = std::exp(-0.5 * kR * kR);
    x[0] = kV / f;
    x[1] = kR;
    x[kLayers] = 0.0;
    for (int i = 2; i < kLayers; ++i) {
      x[i] = std::sqrt(-2.0 * std::log(kV / x[i - 1] + f));
      f = std::exp(-0.5 * x[i] * x[i]);
    }
    for (int i = 0; i < kLayers; ++i) ratio[i] = x[i + 1] / x[i];
  }
};

const Ziggurat& ziggurat() {
  static const Ziggurat z;
  return z;
}

// The tail beyond R (Marsaglia 1964), from a stream of its own: normalFromKey has already used
// mix64(key) for the layer and the sign, so the tail's uniforms start from key with other bits.
double tail(std::uint64_t key, bool negative) {
  std::uint64_t s = key ^ 0xE7037ED1A0B428DBull;
  double x, y;
  do {
    s = mix64(s);
    x = std::log(1.0 - toUnit(s)) / kR;
    s = mix64(s);
    y = std::log(1.0 - toUnit(s));
  } while (-2.0 * y < x * x);
  return negative ? x - kR : kR - x;
}

}  // namespace

const ZigguratTables& zigguratTables() {
  static const ZigguratTables t{ziggurat().x.data(), ziggurat().ratio.data()};
  return t;
}

double normalFromKey(std::uint64_t key) {
  const Ziggurat& z = ziggurat();
  for (;;) {
    const std::uint64_t bits = mix64(key);
    const int i = int(bits & (kLayers - 1));         // layer: the low 7 bits
    const double u = signedUnit52(bits);             // the top 52 bits, independent of the layer
    if (std::abs(u) < z.ratio[i]) return u * z.x[i];  // inside the layer's rectangle
    if (i == 0) return tail(key, u < 0);
    const double x = u * z.x[i];
    const double f0 = std::exp(-0.5 * (z.x[i] * z.x[i] - x * x));
    const double f1 = std::exp(-0.5 * (z.x[i + 1] * z.x[i + 1] - x * x));
    if (f1 + toUnit(mix64(key ^ 0xA0761D6478BD642Full)) * (f0 - f1) < 1.0) return x;
    key = mix64(key);  // a fresh stream for the next try
  }
}

}  // namespace ambler::base
