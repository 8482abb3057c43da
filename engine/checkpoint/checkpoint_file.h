// Checkpoint files: a run's state on disk, written so that a crash at any moment leaves either
// the previous checkpoints or the new one complete, and read back only when whole and meant for
// this scene and this build.
//
// File (DIR/checkpoints/step-<step>.ckpt):
//   "MSIMCKPT"  u32 format  u64 n  header (n bytes)  u64 m  state (m bytes)  u64 FNV-1a of all
//   before it.
// The header names the millsim version, the git commit, the layout signature of this build's
// state records, the scene's hash, the step and the simulated time. Written to a temporary file,
// fsynced, renamed over its final name and the folder fsynced; the newest `keep` are kept.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "checkpoint/archive.h"

namespace millsim {

// 2: multi-rate stepping state; 3: the impact spectrum and the breakage event log; 4: the run
// loop's hold-up history; 5: the mass flows by size class (process/mass_flows.h); 6: the
// neighbour list's turning frame (dem/motion_frame.h); 7: when outlets and feeds were last
// applied, by list (Simulation::process_population), and the kept fluid forces' exchange booked
// by count of steps (sim/multi_rate.h); 8: the hold-up fill's mass, momentum and energy, the
// ledger's filled dust, and the run loop's fill (time.fill_to_projection_s); 9: the dust on the
// compressible gas (the impulse and work the gas gave it, the largest loading); 10: the dust
// ledger's count of speed-bounded slips per class.
inline constexpr std::uint32_t kCheckpointFormat = 10;

struct CheckpointHeader {
  std::string millsim_version;
  std::string git_commit;
  std::uint64_t layout = 0;  // checkpoint_layout() of the build that wrote it
  std::uint64_t scene_hash = 0;
  std::int64_t step = 0;
  double time_s = 0.0;
  double wall_time_s = 0.0;  // of the run so far, over all its attempts
  template <class A>
  void checkpoint_io(A& a) {
    io_all(a, millsim_version, git_commit, layout, scene_hash, step, time_s, wall_time_s);
  }
};

struct Checkpoint {
  std::filesystem::path path;
  CheckpointHeader header;
  std::string state;  // the archive of the run's state
};

// A signature of the byte layout of the state records this build writes raw (sizes of the
// particle, contact, gas and statistics records): checkpoints move only between builds that
// agree on it.
std::uint64_t checkpoint_layout();

// FNV-1a, 64 bits.
std::uint64_t fnv1a64(const void* data, std::size_t n, std::uint64_t hash = 0xcbf29ce484222325ULL);

// The scene's hash: of its JSON text, parsed and dumped with sorted keys (so spacing and key
// order do not matter; every value does).
std::uint64_t scene_hash(const std::string& scene_json_text);

// Writes a file of the checkpoint format at `path` (its folder created if missing): to a
// temporary name, fsynced, renamed over `path`, the folder fsynced. Throws IoError; a failed
// write leaves what was at `path` as it was.
void write_state_file(const std::filesystem::path& path, const CheckpointHeader& header,
                      const std::string& state);

// The gas spin-up's checkpoint in a run's checkpoint folder (sim/gas_spin_up.h): the gas state
// of a spin-up a stop request cut short. Not listed by list_checkpoints (it holds no step).
inline std::filesystem::path spin_up_checkpoint_path(const std::filesystem::path& dir) {
  return dir / "spin-up.ckpt";
}

// Writes the checkpoint into `dir` (created if missing) and removes all but the newest `keep`.
// Throws IoError when it cannot write; a failed write leaves the existing checkpoints as they
// were. Returns the file's path.
std::filesystem::path write_checkpoint(const std::filesystem::path& dir,
                                       const CheckpointHeader& header, const std::string& state,
                                       int keep);

// Reads and verifies one file (magic, format, lengths, checksum). Throws CheckpointError naming
// what is wrong.
Checkpoint read_checkpoint(const std::filesystem::path& path);

// The checkpoint files in `dir`, newest (highest step) first; none when it does not exist.
std::vector<std::filesystem::path> list_checkpoints(const std::filesystem::path& dir);

// Removes every checkpoint file in `dir` (after a run completed), the spin-up's too, and the
// folder if empty.
void remove_checkpoints(const std::filesystem::path& dir);

}  // namespace millsim
