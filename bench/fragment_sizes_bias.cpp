// Fragment sizes against the breakage function (bench/RESULTS.md, "Fragment sizes against the
// breakage function"): the mass-weighted share of fragments below x/y over 20 000 breakages, next
// to B. Not part of the CMake build, because it also compiles against the sampler of commit
// 46c50a0 (without -DNEW, that commit's fragment_sizes.{h,cpp} first on the include path):
//   g++ -std=c++20 -O2 -DNEW -Iengine bench/fragment_sizes_bias.cpp \
//       engine/comminution/fragment_sizes.cpp
#include <cmath>
#include <cstdio>
#include <vector>
#include "comminution/fragment_sizes.h"
using namespace millsim;
int main() {
  struct C {
    const char* name;
    FragmentModel m;
    double q, lo, hi;
  };
  C cs[] = {{"power law q=1 [0.05,0.7]", FragmentModel::PowerLaw, 1.0, 0.05, 0.7},
            {"power law q=2 [0.05,0.5]", FragmentModel::PowerLaw, 2.0, 0.05, 0.5},
            {"Broadbent-Callcott [0.05,0.7]", FragmentModel::BroadbentCallcott, 1.0, 0.05, 0.7}};
  const double at[] = {0.1, 0.2, 0.3, 0.4, 0.5, 0.6};
  for (const C& c : cs) {
    FragmentConfig f;
    f.model = c.m;
    f.exponent = c.q;
    f.min_ratio = c.lo;
    f.max_ratio = c.hi;
    FragmentSizeSampler s(f);
    Rng rng(11);
#ifdef NEW
    FragmentPool pool;
#endif
    std::vector<double> below(6, 0.0);
    double tot = 0;
    for (int e = 0; e < 20000; ++e) {
#ifdef NEW
      auto d = s.draw(1e-4, 0.0, pool, rng);
      std::vector<double> r = d.ratios;
      tot += d.below_floor_volume;
      for (int k = 0; k < 6; ++k) below[k] += d.below_floor_volume;
#else
      std::vector<double> r = s.draw_ratios(rng);
#endif
      for (double x : r) {
        tot += x * x * x;
        for (int k = 0; k < 6; ++k)
          if (x < at[k]) below[k] += x * x * x;
      }
    }
    double worst = 0;
    printf("%s:", c.name);
    for (int k = 0; k < 6; ++k) {
      double B = c.m == FragmentModel::PowerLaw
                     ? (std::pow(std::min(at[k], c.hi), c.q) - std::pow(c.lo, c.q)) /
                           (std::pow(c.hi, c.q) - std::pow(c.lo, c.q))
                     : (std::exp(-c.lo) - std::exp(-std::min(at[k], c.hi))) /
                           (std::exp(-c.lo) - std::exp(-c.hi));
      printf(" %.1f: %.3f/%.3f", at[k], below[k] / tot, B);
      worst = std::max(worst, std::abs(below[k] / tot - B));
    }
    printf("  max |dB| %.4f\n", worst);
  }
}
