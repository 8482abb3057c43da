#include "sim/gas_spin_up.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <memory>
#include <nlohmann/json.hpp>
#include <thread>
#include <vector>

#include "checkpoint/checkpoint_file.h"
#include "core/build_info.h"
#include "core/errors.h"
#include "sim/run.h"

namespace millsim {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// The gas coupling's state as an archive.
std::string gas_state(GasCoupling& gas) {
  ArchiveWriter w;
  io(w, gas);
  return w.data();
}

// Restores a gas state archive; false (and the state before it restored) when it does not read
// whole, with the reason in `why`.
bool restore_gas_state(GasCoupling& gas, const std::string& state, const std::string& before,
                       std::string& why) {
  try {
    ArchiveReader r(state.data(), state.size());
    io(r, gas);
    if (!r.at_end()) throw CheckpointError("its state is longer than this build reads");
    return true;
  } catch (const CheckpointError& e) {
    why = e.what();
    ArchiveReader r(before.data(), before.size());
    io(r, gas);
    return false;
  }
}

// An exclusive lock on a file of the cache, held while one run spins a gas up, so the other
// runs of its study wait and read the result instead of spinning the same gas up at once. The
// kernel drops it when the holder dies.
class CacheLock {
 public:
  explicit CacheLock(const std::filesystem::path& path)
      : fd_(::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644)) {
    if (fd_ < 0) throw IoError("cannot open " + path.string() + ": " + std::strerror(errno));
  }
  ~CacheLock() { ::close(fd_); }  // closing releases the lock
  CacheLock(const CacheLock&) = delete;
  CacheLock& operator=(const CacheLock&) = delete;
  bool try_lock() { return ::flock(fd_, LOCK_EX | LOCK_NB) == 0; }

 private:
  int fd_;
};

// The newest `keep` cache entries stay (a cache serves the studies under way, not every past one).
void prune_cache(const std::filesystem::path& dir, std::size_t keep) {
  std::vector<std::pair<std::filesystem::file_time_type, std::filesystem::path>> entries;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec))
    if (e.path().extension() == ".gas") entries.emplace_back(e.last_write_time(ec), e.path());
  if (entries.size() <= keep) return;
  std::sort(entries.begin(), entries.end(), [](const auto& a, const auto& b) { return a > b; });
  for (std::size_t k = keep; k < entries.size(); ++k) {
    std::filesystem::remove(entries[k].second, ec);
    std::filesystem::path lock = entries[k].second;
    std::filesystem::remove(lock.replace_extension(".lock"), ec);
  }
}

// Reads a cache entry or spin-up checkpoint into the gas when it is whole and meant for it.
// Returns false with the reason otherwise (the gas then as it was).
bool read_gas_file(const std::filesystem::path& path, std::uint64_t expected_hash, bool same_commit,
                   GasCoupling& gas, const std::string& before, CheckpointHeader& header,
                   std::string& why) {
  Checkpoint c;
  try {
    c = read_checkpoint(path);
  } catch (const CheckpointError& e) {
    why = path.string() + ": " + e.what();
    return false;
  }
  header = c.header;
  if (c.header.layout != checkpoint_layout() ||
      (same_commit && c.header.git_commit != kGitCommit)) {
    why = path.string() + ": written by millsim " + c.header.millsim_version + " (commit " +
          c.header.git_commit + "), not this build";
    return false;
  }
  if (c.header.scene_hash != expected_hash) {
    why = path.string() + ": written for another scene";
    return false;
  }
  if (!restore_gas_state(gas, c.state, before, why)) {
    why = path.string() + ": " + why;
    return false;
  }
  return true;
}

}  // namespace

std::filesystem::path spin_up_cache_file(const std::filesystem::path& cache_dir,
                                         std::uint64_t key) {
  char name[32];
  std::snprintf(name, sizeof name, "%016llx.gas", static_cast<unsigned long long>(key));
  return cache_dir / name;
}

std::uint64_t gas_spin_up_key(Simulation& sim, const std::string& scene_text) {
  const nlohmann::json scene = nlohmann::json::parse(scene_text, nullptr, false);
  nlohmann::json inputs = nlohmann::json::object();
  if (scene.is_object())
    for (const char* key : {"gas", "mill", "domain", "gravity_m_per_s2"})
      if (scene.contains(key)) inputs[key] = scene[key];
  // The gas spins up alone: how it will exchange momentum with particles is not among its
  // inputs, so a study over the drag law, its cache or its corrections shares one spin-up.
  if (inputs.contains("gas") && inputs["gas"].is_object())
    for (const char* key :
         {"coupling", "drag", "drag_cache", "drag_courant", "pressure_gradient_force",
          "saffman_lift", "slip_correction", "mach_correction"})
      inputs["gas"].erase(key);
  std::string text = inputs.dump();  // keys sorted: spacing and key order do not matter
  auto append = [&text](const void* data, std::size_t bytes) {
    if (bytes > 0) text.append(static_cast<const char*>(data), bytes);  // data may be null at 0
  };
  const Vec3 cell_m = sim.gas()->table().cell_m();
  const std::uint64_t layout = checkpoint_layout();
  append(&cell_m, sizeof cell_m);
  append(&layout, sizeof layout);
  text.append(kGitCommit);
  // The gas grid as built (cells, face kinds, held values, jet forces): a change to the gas from
  // anywhere else in the scene is another key too. Arrays of scalars only: the state's records
  // hold padding bytes, which differ from process to process.
  const GasGrid& g = sim.gas()->grid();
  append(g.fluid.data(), g.fluid.size());
  for (int a = 0; a < 3; ++a) {
    const std::size_t au = std::size_t(a);
    append(g.face[au].data(), g.face[au].size() * sizeof(FaceKind));
    append(g.fixed_value[au].data(), g.fixed_value[au].size() * sizeof(double));
    append(g.jet_force_n_per_m3[au].data(), g.jet_force_n_per_m3[au].size() * sizeof(double));
  }
  return fnv1a64(text.data(), text.size());
}

SpinUpReport run_gas_spin_up(Simulation& sim, const SpinUpOptions& options) {
  const auto start = Clock::now();
  SpinUpReport report;
  GasCoupling& gas = *sim.gas();
  const double total_s = gas.config().spin_up_s;
  const std::string before = gas_state(gas);
  const std::uint64_t hash = options.scene_text.empty() ? 0 : scene_hash(options.scene_text);
  auto stop_signal = [&] {
    return options.stop_request ? options.stop_request->load(std::memory_order_relaxed) : 0;
  };
  auto progress = [&](double done_s, std::uint64_t steps_here, bool waiting, bool last) {
    if (!options.on_progress) return;
    SpinUpProgress p;
    p.done_s = done_s;
    p.total_s = total_s;
    p.steps = gas.stats().spin_up_steps;
    p.elapsed_s = seconds_since(start);
    const double here_s = done_s - report.resumed_from_s, rate = here_s / (p.elapsed_s + 1e-300);
    p.eta_s = steps_here > 0 && rate > 0.0 ? (total_s - done_s) / rate : 0.0;
    p.waiting = waiting;
    p.last = last;
    options.on_progress(p);
  };

  if (total_s <= 0.0) {  // nothing to spin up
    sim.finish_start();
    report.source = "none";
    report.wall_s = seconds_since(start);
    return report;
  }

  // The shared cache: wait while another run spins the same gas up, then read what it left.
  std::unique_ptr<CacheLock> lock;
  std::uint64_t key = 0;
  if (!options.cache_dir.empty() && !options.scene_text.empty()) {
    key = gas_spin_up_key(sim, options.scene_text);
    report.cache_file = spin_up_cache_file(options.cache_dir, key);
    std::error_code ec;
    std::filesystem::create_directories(options.cache_dir, ec);
    if (ec) throw IoError("cannot create " + options.cache_dir.string() + ": " + ec.message());
    std::filesystem::path lock_path = report.cache_file;
    lock = std::make_unique<CacheLock>(lock_path.replace_extension(".lock"));
    Clock::time_point last_report{};  // long ago: the first wait is reported at once
    const auto wait_start = Clock::now();
    while (!lock->try_lock()) {
      if ((report.interrupted_by = stop_signal()) != 0) {
        report.wall_s = seconds_since(start);
        return report;
      }
      if (seconds_since(last_report) > options.progress_interval_s) {
        progress(0.0, 0, true, false);
        last_report = Clock::now();
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    report.waited_s = seconds_since(wait_start);
    CheckpointHeader header;
    std::string why;
    if (std::filesystem::exists(report.cache_file)) {
      if (read_gas_file(report.cache_file, key, true, gas, before, header, why)) {
        report.source = "cache";
        report.done_s = total_s;
        sim.finish_start();
        progress(total_s, 0, false, true);
        report.wall_s = seconds_since(start);
        return report;
      }
      report.note = "cache entry not used: " + why;
    }
  }

  // A spin-up a stop request cut short continues from its checkpoint.
  const std::filesystem::path checkpoint = options.checkpoint_dir.empty()
                                               ? std::filesystem::path()
                                               : spin_up_checkpoint_path(options.checkpoint_dir);
  if (options.resume && !checkpoint.empty() && std::filesystem::exists(checkpoint)) {
    CheckpointHeader header;
    std::string why;
    if (read_gas_file(checkpoint, hash, false, gas, before, header, why)) {
      report.source = "resumed";
      report.resumed_from_s = gas.stats().spin_up_done_s;
      report.earlier_wall_s = header.wall_time_s;
    } else if (header.layout != 0 && header.layout != checkpoint_layout()) {
      throw ResumeError(why + ": continue it with that build, or run again without --resume");
    } else if (header.layout != 0 && header.scene_hash != hash) {
      throw ResumeError(why +
                        " (the scene changed since it was written): resume with the "
                        "scene it was written for, or run again without --resume");
    } else {
      report.note = "spin-up checkpoint not used, the spin-up starts again: " + why;
    }
  }

  progress(gas.stats().spin_up_done_s, 0, false, false);
  auto last_report = Clock::now();
  std::uint64_t steps_here = 0;
  while (!gas.spin_up_done()) {
    if ((report.interrupted_by = stop_signal()) != 0) break;
    sim.spin_up_gas(1);
    ++steps_here;
    if (seconds_since(last_report) > options.progress_interval_s) {
      progress(gas.stats().spin_up_done_s, steps_here, false, false);
      last_report = Clock::now();
    }
  }
  report.done_s = gas.stats().spin_up_done_s;
  if (report.interrupted_by != 0) {
    if (!checkpoint.empty()) {
      const CheckpointHeader header{kMillsimVersion,
                                    kGitCommit,
                                    checkpoint_layout(),
                                    hash,
                                    0,
                                    report.done_s - total_s,
                                    report.earlier_wall_s + seconds_since(start)};
      write_state_file(checkpoint, header, gas_state(gas));
    }
    report.wall_s = seconds_since(start);
    return report;
  }
  if (lock) {
    const CheckpointHeader header{kMillsimVersion,     kGitCommit, checkpoint_layout(), key, 0, 0.0,
                                  seconds_since(start)};
    write_state_file(report.cache_file, header, gas_state(gas));
    report.cache_written = true;
    lock.reset();
    prune_cache(options.cache_dir, 16);
  }
  sim.finish_start();
  progress(total_s, steps_here, false, true);
  report.wall_s = seconds_since(start);
  return report;
}

}  // namespace millsim
