// Error kinds of the engine (STYLE §7.4): bad input is collected as a list of InputError
// (path, value, allowed) before anything runs; a numerical failure is a StepFailure value;
// environment failures (I/O) are exceptions caught at the process boundary.
#pragma once

#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace millsim {

// One bad input value. `path` is a JSON pointer into the input (e.g. "/materials/0/restitution")
// or a file:line location; `value` is the offending value as written; `allowed` says what is.
struct InputError {
  std::string path;
  std::string value;
  std::string allowed;
};
using InputErrors = std::vector<InputError>;

std::string format_input_error(const InputError& error);
// Problems listed in one report (CLI or HTTP); the count says how many there were in all.
inline constexpr std::size_t kMaxReportedErrors = 100;
std::string format_input_errors(const std::string& source, const InputErrors& errors);

// Thrown only at load boundaries (scene loading, particle files) to carry a full error list.
class InputErrorList : public std::runtime_error {
 public:
  explicit InputErrorList(InputErrors errors);
  const InputErrors& errors() const { return errors_; }

 private:
  InputErrors errors_;
};

// Environment failure: a file that cannot be read or written, a full disk.
class IoError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A run stopped by the stability guard: what, where, when, and how to fix it.
struct StepFailure {
  std::int64_t step = 0;
  double time_s = 0.0;
  std::uint64_t particle_id = 0;  // 0 when no single particle is to blame
  std::string cause;              // short stable keyword: "non_finite_state", ...
  std::string detail;             // the human message, naming the likely fix
};

// Builds a message from streamable parts; GCC 12 has no std::format.
template <class... Parts>
std::string concat(const Parts&... parts) {
  std::ostringstream out;
  out.precision(6);
  (out << ... << parts);
  return out.str();
}

}  // namespace millsim
