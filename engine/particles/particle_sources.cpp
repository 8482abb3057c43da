#include "particles/particle_sources.h"

#include "io/input_file.h"

#include "core/json_reader.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>
#include <unordered_map>

namespace millsim {
namespace {

std::vector<std::string> split_words(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> words;
  for (std::string w; in >> w;) words.push_back(w);
  return words;
}

std::vector<double> header_numbers(const ParticleFile& file, const std::string& key,
                                   std::size_t count, const std::string& where) {
  auto it = file.header.find(key);
  std::vector<double> values;
  if (it != file.header.end())
    for (const std::string& w : split_words(it->second))
      values.push_back(std::strtod(w.c_str(), nullptr));
  if (values.size() != count)
    throw InputErrorList(
        {{where + ": header '" + key + "'", it == file.header.end() ? "" : it->second,
          concat("expected ", count, " number(s)")}});
  return values;
}

}  // namespace

ParticleFile read_particle_file(const std::filesystem::path& path, const InputFileRules& rules) {
  std::istringstream in(read_input_file(path, rules));
  ParticleFile file;
  InputErrors errors;
  std::string line;
  for (std::size_t line_no = 1; std::getline(in, line); ++line_no) {
    if (line.empty()) continue;
    const std::string where = path.filename().string() + ":" + std::to_string(line_no);
    if (line[0] == '#') {
      const auto colon = line.find(':');
      if (colon == std::string::npos) continue;
      std::string key = line.substr(1, colon - 1);
      key.erase(0, key.find_first_not_of(' '));
      key.erase(key.find_last_not_of(' ') + 1);
      std::string value = line.substr(colon + 1);
      value.erase(0, value.find_first_not_of(' '));
      file.header[key] = value;
      continue;
    }
    std::istringstream fields(line);
    double id, x, y, z, d, vx, vy, vz;  // id is read for the column count, then dropped
    if (!(fields >> id >> x >> y >> z >> d >> vx >> vy >> vz)) {
      errors.push_back(
          {where, valid_utf8(utf8_prefix(line, 60)), "expected 8 numbers: id x y z d vx vy vz"});
    } else if (!(d > 0.0) || !std::isfinite(x + y + z + vx + vy + vz)) {
      errors.push_back(
          {where, valid_utf8(utf8_prefix(line, 60)), "expected finite values and a diameter > 0"});
    } else {
      file.particles.push_back({{x, y, z}, {vx, vy, vz}, {}, d});
    }
    if (errors.size() >= 20) break;
  }
  if (!errors.empty()) throw InputErrorList(std::move(errors));
  auto n = file.header.find("N");
  if (n != file.header.end()) {
    // A whole number and nothing else ("abc" or "12abc" is not a count).
    std::uint64_t count = 0;
    const char* first = n->second.data();
    const char* last = first + n->second.size();
    const auto [end, ec] = std::from_chars(first, last, count);
    if (ec != std::errc() || end != last || count != file.particles.size())
      throw InputErrorList(
          {{path.filename().string() + ": header 'N'", valid_utf8(utf8_prefix(n->second, 60)),
            concat("expected the number of particle lines, ", file.particles.size())}});
  }
  return file;
}

SceneConfig scene_from_particle_file(const std::filesystem::path& path, std::int64_t steps) {
  const ParticleFile file = read_particle_file(path);
  const std::string where = path.filename().string();
  SceneConfig scene;
  scene.name = path.stem().string();
  const std::vector<double> box = header_numbers(file, "box", 6, where);
  scene.domain.min_m = {box[0], box[2], box[4]};
  scene.domain.max_m = {box[1], box[3], box[5]};
  auto boundary = file.header.find("boundary");
  const std::vector<std::string> words =
      boundary == file.header.end() ? std::vector<std::string>{} : split_words(boundary->second);
  for (int a = 0; a < 3; ++a)
    scene.domain.periodic[a] = a < int(words.size()) && words[a] == "periodic";
  MaterialConfig m;
  m.name = "bench";
  m.youngs_modulus_pa = header_numbers(file, "youngs_modulus_E", 1, where)[0];
  m.poisson_ratio = header_numbers(file, "poisson_ratio_nu", 1, where)[0];
  m.density_kg_per_m3 = header_numbers(file, "density_rho", 1, where)[0];
  m.restitution = header_numbers(file, "restitution_e", 1, where)[0];
  m.friction = header_numbers(file, "friction_mu", 1, where)[0];
  scene.materials.push_back(m);
  const std::vector<double> g = header_numbers(file, "gravity", 3, where);
  scene.gravity_m_per_s2 = {g[0], g[1], g[2]};
  const double dt = header_numbers(file, "dt", 1, where)[0];
  scene.time.step_s = dt;
  scene.time.end_s = dt * double(steps);
  SourceConfig source;
  source.kind = SourceKind::File;
  source.file_path = path;
  scene.sources.push_back(source);
  scene.output.write_h5 = false;
  scene.base_dir = path.parent_path();
  return scene;
}

double sample_diameter(const SizeDistribution& s, Rng& rng) {
  switch (s.kind) {
    case SizeDistributionKind::Fixed:
      return s.diameter_m;
    case SizeDistributionKind::Uniform:
      return s.min_m + (s.max_m - s.min_m) * uniform01(rng);
    case SizeDistributionKind::LogNormal:
      for (int attempt = 0; attempt < 1000; ++attempt) {
        const double d = s.median_m * std::exp(std::log(s.geometric_std) * gaussian(rng, 0.0, 1.0));
        if (d >= s.min_m && d <= s.max_m) return d;
      }
      return std::clamp(s.median_m, s.min_m, s.max_m);
    case SizeDistributionKind::PowerLaw: {
      const double u = uniform01(rng), p = s.exponent + 1.0;
      if (std::abs(p) < 1e-12) return s.min_m * std::pow(s.max_m / s.min_m, u);
      const double a = std::pow(s.min_m, p), b = std::pow(s.max_m, p);
      return std::pow(a + u * (b - a), 1.0 / p);
    }
  }
  return s.diameter_m;
}

double smallest_diameter_m(const SizeDistribution& s) {
  return s.kind == SizeDistributionKind::Fixed ? s.diameter_m : s.min_m;
}

namespace {

// ∫ x³ n(x) dx from the distribution's lower end to d (within its range), unnormalised; a
// distribution of one size is mass_share_below's own case.
double third_moment_below(const SizeDistribution& s, double d) {
  switch (s.kind) {
    case SizeDistributionKind::Fixed:
      break;
    case SizeDistributionKind::Uniform:
      return std::pow(d, 4) - std::pow(s.min_m, 4);
    case SizeDistributionKind::PowerLaw: {
      const double p = s.exponent + 4.0;
      if (std::abs(p) < 1e-12) return std::log(d / s.min_m);
      return (std::pow(d, p) - std::pow(s.min_m, p)) / p;
    }
    case SizeDistributionKind::LogNormal: {
      const double sigma = std::log(s.geometric_std);
      const double mass_median_log = std::log(s.median_m) + 3.0 * sigma * sigma;
      const auto below = [&](double x) {  // Φ((ln x − ln d_m) / σ); 0 at x = 0
        if (!(x > 0.0)) return 0.0;
        return 0.5 * std::erfc(-(std::log(x) - mass_median_log) / (sigma * std::numbers::sqrt2));
      };
      return below(d) - below(s.min_m);
    }
  }
  return 0.0;
}

}  // namespace

double mass_share_below(const SizeDistribution& s, double d) {
  // One size alone: a fixed one, a range of no width, a log-normal with σ_g = 1 (its median
  // clamped into its range).
  const bool log_normal = s.kind == SizeDistributionKind::LogNormal;
  if (s.kind == SizeDistributionKind::Fixed || !(s.max_m > s.min_m) ||
      (log_normal && !(std::log(s.geometric_std) > 1e-12))) {
    const double only = s.kind == SizeDistributionKind::Fixed ? s.diameter_m
                        : log_normal ? std::clamp(s.median_m, s.min_m, s.max_m)
                                     : s.min_m;
    return only < d ? 1.0 : 0.0;
  }
  if (!(d > s.min_m)) return 0.0;
  if (d >= s.max_m) return 1.0;
  const double whole = third_moment_below(s, s.max_m);
  return whole > 0.0 ? std::clamp(third_moment_below(s, d) / whole, 0.0, 1.0) : 0.0;
}

bool region_wraps(const SourceConfig& source, const PeriodicBox& box, int axis) {
  return box.periodic[std::size_t(axis)] && source.region_min_m[axis] <= box.min_m[axis] &&
         source.region_max_m[axis] >= box.max_m[axis];
}

std::vector<ParticleSpec> random_packing(const SourceConfig& source, const PeriodicBox& box,
                                         const std::vector<ParticleSpec>& existing, Rng& rng,
                                         const std::string& path, InputErrors& errors) {
  std::vector<double> diameters(std::size_t(source.count));
  for (double& d : diameters) d = sample_diameter(source.sizes, rng);
  std::sort(diameters.begin(), diameters.end(), std::greater<>());  // largest first: RSA packs best
  double d_max = diameters.empty() ? 0.0 : diameters.front();
  for (const ParticleSpec& p : existing) d_max = std::max(d_max, p.diameter_m);

  // Hashed cells of edge >= d_max: any overlapping pair sits in neighbouring cells. On periodic
  // axes the cell count divides the length and indices wrap.
  bool wraps[3];
  long long wrap_count[3];
  double cell[3];
  for (int a = 0; a < 3; ++a) {
    wraps[a] = region_wraps(source, box, a);
    wrap_count[a] = wraps[a] ? std::max(1LL, (long long)(box.length(a) / d_max)) : 0;
    cell[a] = wraps[a] ? box.length(a) / double(wrap_count[a]) : d_max;
  }
  auto cell_index = [&](const Vec3& x, int a, long long offset) {
    long long c = (long long)std::floor((x[a] - box.min_m[a]) / cell[a]) + offset;
    if (wraps[a]) c = ((c % wrap_count[a]) + wrap_count[a]) % wrap_count[a];
    return c;
  };
  auto key = [](long long i, long long j, long long k) {
    return (i * 73856093LL) ^ (j * 19349663LL) ^ (k * 83492791LL);
  };
  std::unordered_multimap<long long, std::size_t> cells;
  std::vector<ParticleSpec> placed_all = existing;
  auto insert = [&](std::size_t index) {
    const Vec3& x = placed_all[index].position_m;
    cells.emplace(key(cell_index(x, 0, 0), cell_index(x, 1, 0), cell_index(x, 2, 0)), index);
  };
  for (std::size_t i = 0; i < placed_all.size(); ++i) insert(i);
  auto overlaps = [&](const Vec3& x, double r) {
    for (long long di = -1; di <= 1; ++di)
      for (long long dj = -1; dj <= 1; ++dj)
        for (long long dk = -1; dk <= 1; ++dk) {
          auto range = cells.equal_range(
              key(cell_index(x, 0, di), cell_index(x, 1, dj), cell_index(x, 2, dk)));
          for (auto it = range.first; it != range.second; ++it) {
            const ParticleSpec& o = placed_all[it->second];
            const double reach = r + 0.5 * o.diameter_m;
            if (norm2(box.minimum_image(o.position_m - x)) < reach * reach) return true;
          }
        }
    return false;
  };

  std::vector<ParticleSpec> out;
  for (double d : diameters) {
    const double r = 0.5 * d;
    bool placed = false;
    for (int attempt = 0; attempt < 2000 && !placed; ++attempt) {
      Vec3 x;
      int too_narrow = -1;  // an axis along which the region cannot hold the particle whole
      for (int a = 0; a < 3; ++a) {
        const double margin = wraps[a] ? 0.0 : r;
        const double lo = source.region_min_m[a] + margin, hi = source.region_max_m[a] - margin;
        if (hi < lo) too_narrow = a;
        x[a] = lo + (hi - lo) * uniform01(rng);
      }
      if (too_narrow >= 0) {
        errors.push_back(
            {path, std::to_string(source.count),
             concat("placed ", out.size(), " particles; the next (d = ", d,
                    " m) does not fit the region whole along ", "xyz"[too_narrow], " (extent ",
                    source.region_max_m[too_narrow] - source.region_min_m[too_narrow],
                    " m); enlarge the region")});
        return out;
      }
      if (overlaps(x, r)) continue;
      ParticleSpec p;
      p.position_m = x;
      p.diameter_m = d;
      for (int a = 0; a < 3; ++a)
        p.velocity_m_per_s[a] =
            source.velocity_m_per_s[a] + (source.velocity_spread_m_per_s > 0
                                              ? gaussian(rng, 0.0, source.velocity_spread_m_per_s)
                                              : 0.0);
      placed_all.push_back(p);
      insert(placed_all.size() - 1);
      out.push_back(p);
      placed = true;
    }
    if (!placed) {
      errors.push_back(
          {path, std::to_string(source.count),
           concat("could place only ", out.size(), " particles without overlap (next d = ", d,
                  " m); enlarge the region or lower the count")});
      return out;
    }
  }
  return out;
}

}  // namespace millsim
