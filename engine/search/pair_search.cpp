#include "search/pair_search.h"

#include <algorithm>
#include <cmath>

namespace millsim {

void find_pairs_all_pairs(const std::vector<Vec3>& x, const std::vector<double>& r,
                          const PeriodicBox& box, double skin, PairList& out) {
  out.clear();
  const std::size_t n = x.size();
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      const Vec3 d = box.minimum_image(x[i] - x[j]);
      const double reach = r[i] + r[j] + skin;
      if (norm2(d) < reach * reach) out.push(std::uint32_t(i), std::uint32_t(j));
    }
}

}  // namespace millsim
