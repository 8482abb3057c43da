#include "studies/study.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>
#include <unordered_set>

#include "core/json_reader.h"
#include "io/input_file.h"
#include "memory_reserve.h"
#include "scene/scene_json.h"

namespace millsim {
namespace {

using nlohmann::json;

struct Parameter {
  std::string path;
  std::vector<json> values;
};

std::vector<json> range_values(const json& v, const std::string& path, InputErrors& errors) {
  JsonObjectReader r(v, path, errors);
  const double from = r.required_number("from", NumberRange::any());
  const double to = r.required_number("to", NumberRange::any());
  const long long count = r.integer("count", 0, 1, 100000);
  const std::optional<double> step = r.optional_number("step", NumberRange::positive());
  const std::string spacing = r.string("spacing", "linear", {"linear", "log"});
  r.finish();
  std::vector<json> out;
  if (!errors.empty()) return out;
  if (step) {
    if (r.has("count")) errors.push_back({path, "", "give either count or step, not both"});
    for (double x = from; x <= to * (1 + 1e-12) && out.size() < 100001; x += *step)
      out.push_back(std::abs(x - std::round(x)) < 1e-12 ? json(std::llround(x)) : json(x));
    return out;
  }
  if (count < 1) {
    errors.push_back({path + "/count", "", "missing; expected count (>= 1) or step"});
    return out;
  }
  if (spacing == "log" && (from <= 0 || to <= 0)) {
    errors.push_back({path + "/from", concat(from), "log spacing needs from and to > 0"});
    return out;
  }
  for (long long k = 0; k < count; ++k) {
    const double t = count == 1 ? 0.0 : double(k) / double(count - 1);
    out.push_back(spacing == "log" ? from * std::pow(to / from, t) : from + (to - from) * t);
  }
  return out;
}

std::vector<Parameter> parse_parameters(JsonObjectReader& top, InputErrors& errors) {
  std::vector<Parameter> out;
  const json* list = top.array("parameters");
  if (!list) return out;
  std::unordered_set<std::string> seen;  // a hash set: linear in the number of parameters
  for (std::size_t i = 0; i < list->size(); ++i) {
    const std::string path = json_pointer_join("/parameters", i);
    JsonObjectReader r((*list)[i], path, errors);
    Parameter p;
    p.path = r.required_string("path");
    if (const json* values = r.array("values")) {
      if (values->empty())
        errors.push_back({r.path_of("values"), "[]", "expected at least one value"});
      for (const json& v : *values) p.values.push_back(v);
      if (r.has("range")) errors.push_back({path, "", "give either values or range, not both"});
    } else if (const json* range = r.child("range")) {
      p.values = range_values(*range, r.path_of("range"), errors);
    } else if (r.is_object()) {
      errors.push_back({path, "", "expected values (a list) or range {from, to, count|step}"});
    }
    r.finish();
    if (!seen.insert(p.path).second)
      errors.push_back(
          {r.path_of("path"), concat('"', utf8_prefix(p.path, 200), '"'), "each parameter once"});
    out.push_back(std::move(p));
  }
  return out;
}

// Sets doc at the key path; creates missing object keys, never missing array elements.
bool set_at(json& doc, const std::vector<std::string>& keys, const json& value,
            std::string& problem) {
  json* node = &doc;
  for (std::size_t k = 0; k < keys.size(); ++k) {
    const std::string& key = keys[k];
    const bool last = k + 1 == keys.size();
    if (node->is_array()) {
      char* end = nullptr;
      const long index = std::strtol(key.c_str(), &end, 10);
      if (key.empty() || *end != '\0' || index < 0 || std::size_t(index) >= node->size()) {
        problem = concat("\"", key, "\" is not an index of the ", node->size(), "-element array");
        return false;
      }
      node = &(*node)[std::size_t(index)];
    } else if (node->is_object() || node->is_null()) {
      node = &(*node)[key];
    } else {
      problem = concat("\"", key, "\" is below a value that is not an object or array");
      return false;
    }
    if (last) *node = value;
  }
  return true;
}

// A value that can go into an sbatch command line unquoted and mean only itself.
bool is_slurm_word(const std::string& s) {
  if (s.empty() || s.size() > 128) return false;
  for (const char c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || std::strchr("_.,:=+/-", c))) return false;
  return true;
}

}  // namespace

void parse_slurm(const json& value, SlurmOptions& out, InputErrors& errors) {
  JsonObjectReader r(value, "/slurm", errors);
  const std::string word = "1-128 characters of letters, digits and _ . , : = + / -";
  for (auto [key, field] : {std::pair<const char*, std::string*>{"partition", &out.partition},
                            {"account", &out.account},
                            {"qos", &out.qos}}) {
    *field = r.string(key, "");
    if (r.has(key) && !is_slurm_word(*field))
      errors.push_back({r.path_of(key), "\"" + *field + "\"", "expected " + word});
  }
  if (const json* args = r.array("sbatch_args"))
    for (std::size_t i = 0; i < args->size(); ++i) {
      const json& a = (*args)[i];
      const std::string text = a.is_string() ? a.get<std::string>() : "";
      if (!a.is_string() || text.rfind("--", 0) != 0 || !is_slurm_word(text))
        errors.push_back({json_pointer_join("/slurm/sbatch_args", i), json_value_text(a),
                          "expected an sbatch option \"--name\" or \"--name=value\" of " + word});
      else
        out.sbatch_args.push_back(text);
    }
  r.finish();
}

namespace {

// "run 3 (dust.threshold_diameter_m = 8e-05)": at most about 200 characters of the point, so
// the text of every error stays short however many parameters a study varies.
std::string describe_run(std::size_t index, const json& params) {
  std::string text;
  for (const auto& [key, value] : params.items()) {
    if (text.size() > 200) {
      text += ", ...";
      break;
    }
    if (!text.empty()) text += ", ";
    text += utf8_prefix(key, 100);
    text += " = ";
    text += utf8_prefix(value.dump(), 100);
  }
  return concat("run ", index, " (", text, ")");
}

// The smallest number of bytes a run's scene can take as text: the base scene less everything
// the parameters replace (a parameter's value is at least one byte).
std::size_t smallest_run_bytes(const json& scene, const std::vector<std::string>& paths) {
  std::size_t bytes = scene.dump().size();
  for (const std::string& path : paths) {
    const json* node = &scene;
    for (const std::string& key : parameter_keys(path)) {
      if (node->is_object() && node->contains(key)) {
        node = &(*node)[key];
      } else if (node->is_array()) {
        char* end = nullptr;
        const unsigned long index = std::strtoul(key.c_str(), &end, 10);
        const bool valid = !key.empty() && *end == '\0' && index < node->size();
        node = valid ? &(*node)[index] : nullptr;
      } else {
        node = nullptr;
      }
      if (!node) break;
    }
    if (node && node != &scene) bytes -= std::min(bytes, node->dump().size());
  }
  return bytes;
}

}  // namespace

// File sources name paths relative to the scene: make them absolute so a run can start anywhere.
void absolutize_paths(json& scene, const std::filesystem::path& scene_dir) {
  if (!scene.contains("sources") || !scene["sources"].is_array()) return;
  for (json& s : scene["sources"])
    // A type that is not a string is the scene parser's to report (value() would throw).
    if (s.is_object() && s.contains("type") && s["type"] == "file" && s.contains("path") &&
        s["path"].is_string()) {
      const std::filesystem::path p = s["path"].get<std::string>();
      if (p.is_relative())
        s["path"] = (std::filesystem::absolute(scene_dir) / p).lexically_normal().string();
    }
}

// Why `text`, a file path named by a scene in `scene_dir`, may not be opened under `root`
// (empty when it may). Decided from the names alone, and from symlinks inside the root.
std::string file_outside_root(const std::string& text, const std::filesystem::path& scene_dir,
                              const std::filesystem::path& root) {
  const std::filesystem::path p = text;
  if (p.is_absolute()) return "a file path must be relative to the server's scenes root";
  for (const auto& part : p)
    if (part == "..") return "a file path must not leave the server's scenes root (no \"..\")";
  std::error_code ec;
  const std::filesystem::path real_root = std::filesystem::weakly_canonical(root, ec);
  const std::filesystem::path real = std::filesystem::weakly_canonical(scene_dir / p, ec);
  if (ec) return "a file path that cannot be resolved inside the server's scenes root";
  const auto [root_end, unused] =
      std::mismatch(real_root.begin(), real_root.end(), real.begin(), real.end());
  if (root_end != real_root.end())
    return "a file path must stay inside the server's scenes root (it leads out by a symlink)";
  return {};
}

// Every file source of `scene` checked against `root`; problems as input errors under `prefix`.
void check_files_inside_root(const json& scene, const std::filesystem::path& scene_dir,
                             const std::filesystem::path& root, const std::string& prefix,
                             InputErrors& errors) {
  if (!scene.contains("sources") || !scene["sources"].is_array()) return;
  for (std::size_t k = 0; k < scene["sources"].size(); ++k) {
    const json& s = scene["sources"][k];
    if (!s.is_object() || !s.contains("path") || !s["path"].is_string()) continue;
    const std::string text = s["path"].get<std::string>();
    const std::string problem = file_outside_root(text, scene_dir, root);
    if (!problem.empty())
      errors.push_back({concat(prefix, "/sources/", k, "/path"),
                        concat('"', utf8_prefix(valid_utf8(text), 200), '"'), problem});
  }
}

json read_json_file(const std::filesystem::path& path, const std::string& what) {
  std::string text;
  try {
    text = read_input_file(path, {});
  } catch (const InputFileRefused& e) {
    throw InputErrorList({{what, path.string(), e.what()}});
  } catch (const IoError&) {
    throw InputErrorList({{what, path.string(), "cannot read this file"}});
  }
  try {
    return parse_untrusted_json(text);
  } catch (const json::exception& e) {  // syntax, or a number beyond a double (1e999)
    throw InputErrorList({{what, path.string(), std::string("not valid JSON: ") + e.what()}});
  } catch (const JsonTooDeep& e) {
    throw InputErrorList({{what, path.string(), e.what()}});
  }
}

json SlurmOptions::to_json() const {
  json j = json::object();
  if (!partition.empty()) j["partition"] = partition;
  if (!account.empty()) j["account"] = account;
  if (!qos.empty()) j["qos"] = qos;
  if (!sbatch_args.empty()) j["sbatch_args"] = sbatch_args;
  return j;
}

SlurmOptions SlurmOptions::from_json(const json& j) {
  SlurmOptions o;
  InputErrors ignored;
  if (j.is_object()) parse_slurm(j, o, ignored);
  return ignored.empty() ? o : SlurmOptions{};
}

std::vector<std::string> parameter_keys(const std::string& path) {
  std::vector<std::string> keys;
  const char separator = !path.empty() && path[0] == '/' ? '/' : '.';
  std::string key;
  for (std::size_t i = separator == '/' ? 1 : 0; i <= path.size(); ++i) {
    if (i == path.size() || path[i] == separator) {
      keys.push_back(key);
      key.clear();
    } else {
      key += path[i];
    }
  }
  return keys;
}

StudyTooLarge::StudyTooLarge(const std::string& what)
    : std::runtime_error(what +
                         " (millsim serve --max-study-bytes): use fewer runs or a smaller inline "
                         "scene; nothing was queued") {}

Study expand_study(const json& spec, const std::filesystem::path& base_dir, int max_runs,
                   const std::filesystem::path* files_root, std::size_t max_stored_bytes) {
  InputErrors errors;
  Study study;
  study.spec = spec;
  JsonObjectReader top(spec, "", errors);
  if (!top.is_object()) throw InputErrorList(std::move(errors));
  study.name = top.string("name", "study");
  study.description = top.string("description", "");

  // The base scene: inline, or a path relative to the study file.
  json scene;
  std::filesystem::path scene_dir = base_dir;
  if (const json* s = top.child("scene")) {
    if (s->is_string()) {
      std::filesystem::path p = s->get<std::string>();
      if (p.is_relative()) p = base_dir / p;
      scene_dir = p.parent_path();
      std::error_code ec;  // a name too long for the system is as missing as any other
      if (!std::filesystem::is_regular_file(p, ec))
        errors.push_back(
            {"/scene", s->dump(), "no such scene file (looked at " + p.string() + ")"});
      else
        scene = read_json_file(p, "/scene");
    } else if (s->is_object()) {
      scene = *s;
    } else {
      errors.push_back({"/scene", json_value_text(*s), "expected a scene object or a path"});
    }
  } else {
    errors.push_back({"/scene", "", "missing; expected a scene object or a path"});
  }
  if (const json* set = top.child("set")) {
    if (!set->is_object())
      errors.push_back({"/set", json_value_text(*set), "expected an object {path: value}"});
    else
      for (const auto& [path, value] : set->items()) {
        std::string problem;
        if (scene.is_object() && !set_at(scene, parameter_keys(path), value, problem))
          errors.push_back({"/set/" + path, value.dump(), problem});
      }
  }
  const std::vector<Parameter> parameters = parse_parameters(top, errors);
  const std::string combine = top.string("combine", "grid", {"grid", "zip"});
  const int repeats = int(top.integer("repeats", 1, 1, 1000));
  study.error_metric = top.string("error", "");
  if (!study.error_metric.empty() && study.error_metric[0] != '/' &&
      study.error_metric != "psd_ks" && study.error_metric != "psd_l1" &&
      study.error_metric != "d50" && study.error_metric != "total_psd_ks" &&
      study.error_metric != "total_psd_l1")
    errors.push_back({"/error", "\"" + study.error_metric + "\"",
                      "expected psd_ks, psd_l1, d50, total_psd_ks, total_psd_l1 or a JSON "
                      "pointer into result.json (e.g. /energy/final/kinetic_j)"});
  if (const json* l = top.child("limits")) {
    JsonObjectReader r(*l, "/limits", errors);
    study.limits.wall_time_s = r.number("wall_time_s", 3600.0, NumberRange::open_closed(0, 1e7));
    study.limits.memory_mb = r.number("memory_mb", 4096.0, NumberRange::closed(16, 1e7));
    study.limits.max_attempts = int(r.integer("max_attempts", 3, 1, 100));
    study.limits.threads_per_run = int(r.integer("threads_per_run", 1, 1, 1024));
    r.finish();
  }
  if (const json* sl = top.child("slurm")) parse_slurm(*sl, study.slurm, errors);
  const json* reference = top.child("reference");
  if (reference && !reference->is_object())
    errors.push_back({"/reference", json_value_text(*reference), "expected {path: value}"});
  // Overrides for the reference run alone, e.g. the outputs a user opens (run.h5 for ParaView).
  const json* reference_set = top.child("reference_set");
  if (reference_set && !reference_set->is_object())
    errors.push_back(
        {"/reference_set", json_value_text(*reference_set), "expected an object {path: value}"});
  if (reference_set && reference_set->is_object() && !reference)
    errors.push_back(
        {"/reference_set", reference_set->dump(), "needs a reference: the run it applies to"});
  top.finish();

  // The points: a full grid (last parameter fastest) or zipped lists of equal length.
  std::size_t points = 1;
  if (combine == "zip" && !parameters.empty()) {
    points = parameters[0].values.size();
    for (std::size_t i = 1; i < parameters.size(); ++i)
      if (parameters[i].values.size() != points)
        errors.push_back({json_pointer_join("/parameters", i), "",
                          concat("zip needs lists of equal length: ", parameters[i].values.size(),
                                 " values against ", points)});
  } else {
    for (const Parameter& p : parameters) {
      points *= std::max<std::size_t>(p.values.size(), 1);
      if (points > 1'000'000) break;
    }
  }
  const double total = double(points) * repeats;
  if (total > max_runs)
    errors.push_back(
        {"/parameters", "",
         concat("the study expands to ", total, " runs; this service allows at most ", max_runs)});
  // The runs are expanded and validated even when the study's own fields have problems, so every
  // problem is reported at once; only a study that cannot be expanded stops here.
  bool expandable = scene.is_object() && total <= max_runs;
  std::unordered_set<std::string> distinct;  // a parameter given twice leaves its runs undefined
  for (const Parameter& p : parameters)
    expandable = expandable && !p.values.empty() && distinct.insert(p.path).second;
  if (combine == "zip")
    for (const Parameter& p : parameters)
      expandable = expandable && p.values.size() == parameters[0].values.size();
  if (!expandable) throw InputErrorList(std::move(errors));
  // The stored size bounded before anything is expanded, then counted as the runs are made.
  if (max_stored_bytes > 0) {
    std::vector<std::string> paths;
    for (const Parameter& p : parameters) paths.push_back(p.path);
    const double least = double(smallest_run_bytes(scene, paths)) * total;
    if (least > double(max_stored_bytes))
      throw StudyTooLarge(concat("the study would store at least ", least, " bytes of scenes (",
                                 total, " runs), more than this server's limit of ",
                                 max_stored_bytes));
  }
  std::size_t stored_bytes = 0;
  // A problem of the base scene shows in every run: it is reported for the first run only.
  std::set<std::string> seen_scene_problems;
  std::size_t repeated_problems = 0;

  std::uint64_t base_seed =
      scene.is_object() && scene.contains("seed") && scene["seed"].is_number_unsigned()
          ? scene["seed"].get<std::uint64_t>()
          : 1;
  for (std::size_t point = 0; point < points; ++point) {
    json params = json::object();
    std::size_t rest = point;
    for (std::size_t i = parameters.size(); i-- > 0;) {
      const Parameter& p = parameters[i];
      const std::size_t n = p.values.size();
      const std::size_t pick = combine == "zip" ? point : rest % n;
      if (combine != "zip") rest /= n;
      params[p.path] = p.values[pick];
    }
    nlohmann::ordered_json ordered = nlohmann::ordered_json::object();
    for (const Parameter& p : parameters) ordered[p.path] = params[p.path];
    for (int r = 0; r < repeats; ++r) {
      // Memory ran short somewhere in the server while this grew (service/memory_reserve.h):
      // this request gives up, not the server.
      if (memory_reserve_tapped()) throw std::bad_alloc();
      StudyRun run;
      run.index = int(study.runs.size());
      run.params = ordered;
      run.repeat = r;
      run.scene = scene;
      for (const Parameter& p : parameters) {
        std::string problem;
        if (!set_at(run.scene, parameter_keys(p.path), params[p.path], problem))
          errors.push_back({describe_run(run.index, params), p.path, problem});
      }
      if (reference && reference->is_object() && !study.reference_index) {
        bool match = !reference->empty();
        for (const auto& [key, value] : reference->items())
          match = match && params.contains(key) && params[key] == value;
        if (match && r == 0) {
          run.is_reference = true;
          study.reference_index = run.index;
          if (reference_set && reference_set->is_object())
            for (const auto& [path, value] : reference_set->items()) {
              std::string problem;
              if (!set_at(run.scene, parameter_keys(path), value, problem))
                errors.push_back({"/reference_set/" + path, value.dump(), problem});
            }
        }
      }
      run.seed = run.scene.contains("seed") && run.scene["seed"].is_number_unsigned()
                     ? run.scene["seed"].get<std::uint64_t>() + std::uint64_t(r)
                     : base_seed + std::uint64_t(r);
      run.scene["seed"] = run.seed;
      InputErrors scene_errors;
      if (files_root) check_files_inside_root(run.scene, scene_dir, *files_root, "", scene_errors);
      absolutize_paths(run.scene, scene_dir);
      if (scene_errors.empty()) parse_scene(run.scene, scene_dir, scene_errors);
      for (const InputError& e : scene_errors) {
        if (!seen_scene_problems.insert(e.path + '\x1f' + e.value + '\x1f' + e.allowed).second) {
          ++repeated_problems;
          continue;
        }
        errors.push_back(
            {concat(describe_run(run.index, params), " ", e.path), e.value, e.allowed});
      }
      if (max_stored_bytes > 0) {
        stored_bytes += run.scene.dump().size();
        if (stored_bytes > max_stored_bytes)
          throw StudyTooLarge(concat("the study would store more than ", stored_bytes,
                                     " bytes of scenes after ", run.index + 1, " of its ", total,
                                     " runs, more than this server's limit of ", max_stored_bytes));
      }
      study.runs.push_back(std::move(run));
    }
  }
  if (reference && reference->is_object() && !study.reference_index)
    errors.push_back({"/reference", reference->dump(),
                      "matches no point of the study: give one value of each varied parameter"});
  if (repeated_problems > 0)
    errors.push_back(
        {"(other runs)", "", concat(repeated_problems, " more problems repeat the ones above")});
  if (!errors.empty()) throw InputErrorList(std::move(errors));
  return study;
}

Study load_study(const std::filesystem::path& path, int max_runs) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw InputErrorList({{path.string(), "", "no such study file"}});
  return expand_study(read_json_file(path, path.string()), path.parent_path(), max_runs);
}

std::optional<InputError> thread_budget_problem(int threads_per_run, int workers, int cores) {
  if (workers <= 0 || std::int64_t(threads_per_run) * workers <= cores) return std::nullopt;
  return InputError{"/limits/threads_per_run", std::to_string(threads_per_run),
                    concat("at most ", std::max(1, cores / workers), ": ", workers,
                           " local worker(s) would start ", std::int64_t(threads_per_run) * workers,
                           " threads on the ", cores,
                           " core(s) this machine allows (its affinity mask); ask for fewer "
                           "threads per run or run with fewer workers")};
}

}  // namespace millsim
