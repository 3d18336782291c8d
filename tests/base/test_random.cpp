// The random streams against their definitions: mix64 is SplitMix64's output function (checked
// against a reference implementation of Vigna's splitmix64.c and its published outputs for
// seed 0), the bit-to-double conversions are exact, and the ziggurat draws a standard normal
// (moments, tails and layer edges within binomial/standard errors; its fast path as documented).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <algorithm>
#include <vector>

#include "base/random.hpp"

namespace ambler::base {
namespace {

constexpr std::uint64_t kGolden = 0x9E3779B97F4A7C15ull;

// Vigna's splitmix64.c, written out independently of base::mix64: the state advances by the
// golden-ratio increment and the output is the mixed state.
struct ReferenceSplitMix64 {
  std::uint64_t x;
  std::uint64_t next() {
    std::uint64_t z = (x += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }
};

// Φ(t), the standard normal CDF.
double normalCdf(double t) { return 0.5 * std::erfc(-t / std::numbers::sqrt2); }

TEST(Mix64, IsSplitMix64) {
  // SplitMix64's published first outputs for seed 0 (splitmix64.c), and mix64 at compile time.
  static_assert(mix64(0) == 0xe220a8397b1dcdafull);
  ReferenceSplitMix64 ref{0};
  EXPECT_EQ(ref.next(), 0xe220a8397b1dcdafull);
  EXPECT_EQ(ref.next(), 0x6e789e6aa1b965f4ull);
  EXPECT_EQ(ref.next(), 0x06c45d188009454full);
  EXPECT_EQ(ref.next(), 0xf88bb8a8724c81ecull);
  // The k-th output (k = 0, 1, ...) of SplitMix64 seeded with s is mix64(s + k·golden): mix64
  // adds the increment itself.
  for (std::uint64_t seed : {0ull, 1ull, 42ull, 0xFFFFFFFFFFFFFFFFull, 0x0123456789ABCDEFull}) {
    ReferenceSplitMix64 r{seed};
    for (std::uint64_t k = 0; k < 1000; ++k) ASSERT_EQ(mix64(seed + k * kGolden), r.next()) << seed << " " << k;
  }
}

TEST(StreamKey, IsTheDocumentedCompositionAndSeparatesStreams) {
  static_assert(streamKey(7, 3, 5) == mix64(mix64(mix64(7) ^ 3) ^ (5 * 0xD6E8FEB86659FD93ull)));
  static_assert(streamKey(7, 3) == mix64(mix64(mix64(7) ^ 3) ^ 0));
  // 2^20 (a, b) pairs of one seed and the same pairs of another: all keys distinct. mix64 is a
  // bijection, so a collision within a seed needs mix64(s) ^ a ^ b·C to repeat; for random 64-bit
  // keys the chance of any collision among 2^21 is 2^42 / 2^65 ≈ 1e-7.
  std::vector<std::uint64_t> keys;
  for (std::uint64_t seed : {1ull, 2ull})
    for (std::uint64_t a = 0; a < 1024; ++a)
      for (std::uint64_t b = 0; b < 1024; ++b) keys.push_back(streamKey(seed, a, b));
  std::sort(keys.begin(), keys.end());
  EXPECT_EQ(std::adjacent_find(keys.begin(), keys.end()), keys.end());
}

TEST(Rng, IsASplitMix64StreamFromTheMixedSeed) {
  // Rng(seed) starts at state mix64(seed) and returns mix64(state += golden): its k-th output
  // (k = 1, 2, ...) is mix64(mix64(seed) + k·golden), i.e. SplitMix64 from state mix64(seed) + golden.
  for (std::uint64_t seed : {0ull, 3ull, 0xDEADBEEFull}) {
    Rng rng(seed);
    ReferenceSplitMix64 ref{mix64(seed) + kGolden};
    for (std::uint64_t k = 1; k <= 1000; ++k) {
      const std::uint64_t v = rng.next();
      ASSERT_EQ(v, mix64(mix64(seed) + k * kGolden));
      ASSERT_EQ(v, ref.next());
    }
  }
  // The derived draws are the documented functions of next().
  Rng a(9), b(9);
  for (int i = 0; i < 1000; ++i) {
    const std::uint64_t bits = b.next();
    ASSERT_EQ(a.uniform(), toUnit(bits));
  }
  Rng c(10), d(10);
  for (int i = 0; i < 1000; ++i) {
    const double u = toUnit(d.next());
    ASSERT_EQ(c.uniform(-2.5, 4.0), -2.5 + 6.5 * u);
  }
  Rng e(11), f(11);
  for (std::uint64_t n : {1ull, 2ull, 7ull, 1000ull, 0xFFFFFFFFFFFFull}) {
    const std::uint64_t v = e.below(n);
    EXPECT_LT(v, n);
    EXPECT_EQ(v, f.next() % n);
  }
  EXPECT_EQ(e.below(0), 0u);
}

// Box–Muller: mean 0 and variance 1 within 4.5 standard errors (1/√N and √(2/N)).
TEST(Rng, NormalHasUnitVariance) {
  Rng rng(5);
  const int n = 1 << 20;
  double sum = 0, sum2 = 0;
  for (int i = 0; i < n; ++i) {
    const double z = rng.normal();
    ASSERT_TRUE(std::isfinite(z));
    sum += z, sum2 += z * z;
  }
  EXPECT_NEAR(sum / n, 0.0, 4.5 / std::sqrt(n));
  EXPECT_NEAR(sum2 / n, 1.0, 4.5 * std::sqrt(2.0 / n));
}

TEST(ToUnit, ExactOn53BitsInZeroOne) {
  EXPECT_EQ(toUnit(0), 0.0);
  EXPECT_EQ(toUnit(0x7FF), 0.0);  // the low 11 bits are dropped
  EXPECT_EQ(toUnit(1ull << 11), 0x1.0p-53);
  EXPECT_EQ(toUnit(~0ull), 1.0 - 0x1.0p-53);  // the largest value: below 1
  EXPECT_LT(toUnit(~0ull), 1.0);
  EXPECT_EQ(toUnit(1ull << 63), 0.5);
  // Every value is (bits >> 11)·2^−53 exactly: 53 bits fit a double's significand.
  Rng rng(1);
  for (int i = 0; i < 100000; ++i) {
    const std::uint64_t b = rng.next();
    const double u = toUnit(b);
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    ASSERT_EQ(std::ldexp(u, 53), double(b >> 11));
  }
}

TEST(SignedUnit52, ExactOn52BitsInMinusOneOne) {
  EXPECT_EQ(signedUnit52(0), -1.0);
  EXPECT_EQ(signedUnit52(0xFFF), -1.0);  // the low 12 bits (the ziggurat's layer) are dropped
  EXPECT_EQ(signedUnit52(1ull << 12), -1.0 + 0x1.0p-51);
  EXPECT_EQ(signedUnit52(1ull << 63), 0.0);
  EXPECT_EQ(signedUnit52(~0ull), 1.0 - 0x1.0p-51);  // the largest value: below 1
  // Every value is −1 + (bits >> 12)·2^−51 exactly (2·d − 3 with d in [1, 2) loses no bit: the
  // result is a multiple of 2^−51 of magnitude ≤ 1).
  Rng rng(2);
  for (int i = 0; i < 100000; ++i) {
    const std::uint64_t b = rng.next();
    const double u = signedUnit52(b);
    ASSERT_GE(u, -1.0);
    ASSERT_LT(u, 1.0);
    ASSERT_EQ(u, -1.0 + std::ldexp(double(b >> 12), -51));
  }
}

// The tables describe Marsaglia & Tsang's ziggurat: 128 layers of equal area V under
// f(x) = exp(−x²/2), the base strip (a rectangle [0, x0] × [0, f(R)]) holding the tail beyond R = x1.
TEST(Ziggurat, TablesAreEqualAreaLayersUnderTheGaussian) {
  const ZigguratTables& t = zigguratTables();
  auto f = [](double x) { return std::exp(-0.5 * x * x); };
  const double R = t.x[1], V = t.x[0] * f(R);
  EXPECT_EQ(t.x[128], 0.0);
  for (int i = 0; i < 128; ++i) {
    EXPECT_GT(t.x[i], t.x[i + 1]) << i;
    EXPECT_EQ(t.ratio[i], t.x[i + 1] / t.x[i]) << i;
  }
  // The base strip: the rectangle under f(R) up to R plus the tail, R·f(R) + √(π/2)·erfc(R/√2).
  // R and V are published to 13 significant digits (±5e-13 in R); dV/dR = −R²f(R) ≈ −0.032, so
  // the two agree to 1.6e-14 absolute ≈ 1.6e-12 of V, plus a few ulp from exp/erfc.
  const double base = R * f(R) + std::sqrt(std::numbers::pi / 2) * std::erfc(R / std::numbers::sqrt2);
  EXPECT_NEAR(base / V, 1.0, 2e-12);
  // Layer i ≥ 1 is the rectangle [0, x[i]] × [f(x[i]), f(x[i+1])]. Each f carries a relative
  // error ≤ (1 + x²/2)·2ε (exp of a rounded argument) ≤ 6.9·2ε ≈ 3.1e-15 absolute (f ≤ 1, x ≤ R),
  // against a layer height V/x[i] ≥ V/R ≈ 2.9e-3: relative error ≤ 2·3.1e-15 / 2.9e-3 ≈ 2.2e-12.
  for (int i = 1; i < 127; ++i) EXPECT_NEAR(t.x[i] * (f(t.x[i + 1]) - f(t.x[i])) / V, 1.0, 2.2e-12) << i;
}

// The fast path as the header documents it: with bits = mix64(key), layer i = bits & 127 and
// u = signedUnit52(bits), |u| < ratio[i] ⇒ normalFromKey(key) == u·x[i], bit for bit. It is taken
// with probability mean(ratio) (the layer is uniform over 128, u uniform on [−1, 1)), within 4.5
// binomial σ.
TEST(NormalFromKey, FastPathIsTheDocumentedIdentity) {
  const ZigguratTables& t = zigguratTables();
  double mean_ratio = 0;
  for (int i = 0; i < 128; ++i) mean_ratio += t.ratio[i] / 128;
  const int n = 1 << 20;
  int fast = 0;
  for (int k = 0; k < n; ++k) {
    const std::uint64_t key = streamKey(3, std::uint64_t(k));
    const std::uint64_t bits = mix64(key);
    const int i = int(bits & 127);
    const double u = signedUnit52(bits);
    const double z = normalFromKey(key);
    ASSERT_EQ(normalFromKey(key), z);  // a function of the key alone
    if (std::abs(u) < t.ratio[i]) {
      ASSERT_EQ(z, u * t.x[i]) << "key " << key;
      ++fast;
    }
  }
  EXPECT_NEAR(double(fast) / n, mean_ratio, 4.5 * std::sqrt(mean_ratio * (1 - mean_ratio) / n));
}

// N = 2^22 draws from consecutive stream keys: the mean within 4.5/√N, the variance within
// 4.5·√(2/N), and the fraction below each threshold t (Φ(t)) within 4.5 binomial σ √(Φ(1−Φ)/N).
// The thresholds include ±R (the base strip's tail as a whole) and layer edges deep in the
// wedges, so the rectangle, wedge and tail paths are each weighed; the tail's shape beyond R is
// TailBeyondRIsTheNormalTail's.
TEST(NormalFromKey, IsAStandardNormal) {
  const ZigguratTables& t = zigguratTables();
  const int n = 1 << 22;
  std::vector<double> thresholds{-3.0, -2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0, 3.0};
  for (int i : {1, 2, 10, 64, 120, 126, 127}) thresholds.push_back(t.x[i]), thresholds.push_back(-t.x[i]);
  std::vector<long> below(thresholds.size(), 0);
  double sum = 0, sum2 = 0;
  for (int k = 0; k < n; ++k) {
    const double z = normalFromKey(streamKey(17, std::uint64_t(k), 1));
    ASSERT_TRUE(std::isfinite(z));
    sum += z, sum2 += z * z;
    for (std::size_t j = 0; j < thresholds.size(); ++j) below[j] += z < thresholds[j];
  }
  EXPECT_NEAR(sum / n, 0.0, 4.5 / std::sqrt(n));
  EXPECT_NEAR(sum2 / n, 1.0, 4.5 * std::sqrt(2.0 / n));
  for (std::size_t j = 0; j < thresholds.size(); ++j) {
    const double p = normalCdf(thresholds[j]);
    EXPECT_NEAR(double(below[j]) / n, p, 4.5 * std::sqrt(p * (1 - p) / n)) << "threshold " << thresholds[j];
  }
}

// The tail beyond R on each side is the normal's: of N = 2^24 draws, the fraction beyond ±4 and
// ±4.5 (Φ(−t) each) within 4.5 binomial σ, and the fourth moment (3; variance E z^8 − 9 = 96)
// within 4.5·√(96/N).
TEST(NormalFromKey, TailBeyondRIsTheNormalTail) {
  const int n = 1 << 24;
  const std::vector<double> thresholds{-4.5, -4.0, 4.0, 4.5};
  std::vector<long> beyond(thresholds.size(), 0);
  double sum4 = 0;
  for (int k = 0; k < n; ++k) {
    const double z = normalFromKey(streamKey(23, std::uint64_t(k)));
    sum4 += z * z * z * z;
    for (std::size_t j = 0; j < thresholds.size(); ++j)
      beyond[j] += thresholds[j] < 0 ? z < thresholds[j] : z > thresholds[j];
  }
  for (std::size_t j = 0; j < thresholds.size(); ++j) {
    const double p = normalCdf(-std::abs(thresholds[j]));
    EXPECT_NEAR(double(beyond[j]) / n, p, 4.5 * std::sqrt(p * (1 - p) / n)) << "beyond " << thresholds[j];
  }
  EXPECT_NEAR(sum4 / n, 3.0, 4.5 * std::sqrt(96.0 / n));
}

}  // namespace
}  // namespace ambler::base
