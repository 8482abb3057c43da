// Particle sources of a scene: explicit lists, particle files in the shared benchmark format
// (shared/bench/FORMAT.md), and random non-overlapping packings drawn from a size distribution.
// Produces ParticleSpecs only; ParticleStore::add turns them into particles.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "core/errors.h"
#include "core/rng.h"
#include "dem/box.h"
#include "io/input_file.h"
#include "scene/scene_config.h"

namespace millsim {

struct ParticleFile {
  std::map<std::string, std::string> header;  // "# key: value" lines
  std::vector<ParticleSpec> particles;  // the file's ids are not kept: a run numbers particles 1..N
};

// Reads a particle file; throws InputErrorList naming file:line for malformed content,
// InputFileRefused for a file the rules refuse (io/input_file.h) and IoError when it cannot be
// opened.
ParticleFile read_particle_file(const std::filesystem::path& path,
                                const InputFileRules& rules = {});

// Builds a scene from a benchmark particle file's header (box, boundary, material, gravity, dt):
// one material "bench", the file as the only source, fixed time step, end after `steps` steps.
SceneConfig scene_from_particle_file(const std::filesystem::path& path, std::int64_t steps);

// Draws one diameter from the distribution.
double sample_diameter(const SizeDistribution& sizes, Rng& rng);
// The smallest diameter the distribution can draw (0 when it has no lower bound).
double smallest_diameter_m(const SizeDistribution& sizes);
// The share of the mass of particles drawn from the distribution that lies in those smaller
// than `diameter_m`: ∫ x³ n(x) dx up to it over the whole, with n the number density
// sample_diameter draws from (the log-normal's x³ n(x) is a log-normal of median
// exp(3 ln²σ_g) times n's, both truncated alike). What a feed's mass flow holds below a size.
double mass_share_below(const SizeDistribution& sizes, double diameter_m);

// Whether a random source's region spans the whole of periodic axis `axis` of the box: centres
// then fill its length; along any other axis each sphere lies wholly inside the region.
bool region_wraps(const SourceConfig& source, const PeriodicBox& box, int axis);

// Random sequential addition: `count` spheres inside the region, overlapping neither each other
// nor `existing` (under the periodic box's minimum image). On an axis where the region spans a
// periodic domain, centres fill the whole length; elsewhere each sphere lies wholly inside the
// region. Reports an InputError at `path` when the region is too full.
std::vector<ParticleSpec> random_packing(const SourceConfig& source, const PeriodicBox& box,
                                         const std::vector<ParticleSpec>& existing, Rng& rng,
                                         const std::string& path, InputErrors& errors);

}  // namespace millsim
