// Study files (docs/studies.md): a base scene, fixed overrides, the parameters to vary (by their
// key path in the scene, as lists or ranges, combined as a full grid or zipped), an optional
// reference point, repeats with seeds, per-run limits and the error metric. expand_study()
// turns one into its runs and validates every run's scene with the scene loader before
// anything is queued: a bad path or value names the parameter and the point.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/errors.h"

namespace millsim {

struct StudyLimits {
  double wall_time_s = 3600.0;
  double memory_mb = 4096.0;
  int max_attempts = 3;     // system errors are retried up to this many attempts in all
  int threads_per_run = 1;  // `millsim run --threads` of each run (Slurm: --cpus-per-task)
};

// Slurm options of a study's batch jobs (`slurm` key): each becomes one sbatch option, after the
// worker's own, so the study's win. Values are checked (letters, digits and _ . , : = + / -).
struct SlurmOptions {
  std::string partition, account, qos;
  std::vector<std::string> sbatch_args;  // each "--name" or "--name=value"
  bool empty() const {
    return partition.empty() && account.empty() && qos.empty() && sbatch_args.empty();
  }
  nlohmann::json to_json() const;
  static SlurmOptions from_json(const nlohmann::json& j);  // tolerant: unknown or bad = empty
};

struct StudyRun {
  int index = 0;
  nlohmann::ordered_json params;  // {path: value} of the varied parameters
  int repeat = 0;
  std::uint64_t seed = 1;
  nlohmann::json scene;  // the complete scene, file paths made absolute
  bool is_reference = false;
};

struct Study {
  std::string name;
  std::string description;
  nlohmann::json spec;  // as submitted
  std::vector<StudyRun> runs;
  std::optional<int> reference_index;  // the first run at the reference point
  std::string error_metric;            // "psd_ks", "psd_l1", "d50" or a JSON pointer
  StudyLimits limits;
  SlurmOptions slurm;
};

// Parses and expands a study. `base_dir` resolves a scene path (the study file's directory).
// Throws InputErrorList with every problem (paths like /parameters/0/values/2, or
// "run 3 (dust.threshold_diameter_m = 8e-05)" for a scene that does not validate), and when
// the study would have more than `max_runs` runs.
// `files_root` (a server's scenes root, for studies from outside): every file a run's scene
// names must be a relative path without "..", and resolve (symlinks followed) inside it. It is
// checked before the file is opened, and the error names the path, never what is there.
// `max_stored_bytes` (0: none) bounds the runs' scenes as text: a study that must exceed it is
// refused before anything is expanded, one that does is stopped at the run that does; both
// throw StudyTooLarge. Validation is linear in the study's size.
Study expand_study(const nlohmann::json& spec, const std::filesystem::path& base_dir, int max_runs,
                   const std::filesystem::path* files_root = nullptr,
                   std::size_t max_stored_bytes = 0);

// The problem with running a study's runs at `threads_per_run` threads each on `workers` local
// workers when the machine's affinity mask allows `cores` (more threads than cores), or nullopt.
std::optional<InputError> thread_budget_problem(int threads_per_run, int workers, int cores);

// A study whose runs' scenes would exceed the server's --max-study-bytes.
class StudyTooLarge : public std::runtime_error {
 public:
  explicit StudyTooLarge(const std::string& what);
};

// Reads a study file; throws InputErrorList / IoError.
Study load_study(const std::filesystem::path& path, int max_runs);

// Makes the paths of a scene's file sources absolute (relative ones are relative to scene_dir),
// so a run can start in any directory.
void absolutize_paths(nlohmann::json& scene, const std::filesystem::path& scene_dir);

// Reads a JSON file; throws InputErrorList naming `what` when it is missing or not valid JSON.
nlohmann::json read_json_file(const std::filesystem::path& path, const std::string& what);

// Reads a study's `slurm` object (paths /slurm/...); problems go to `errors`.
void parse_slurm(const nlohmann::json& value, SlurmOptions& out, InputErrors& errors);

// Splits "dust.threshold_diameter_m" or "/dust/threshold_diameter_m" into keys.
std::vector<std::string> parameter_keys(const std::string& path);

}  // namespace millsim
