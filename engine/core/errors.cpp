#include "core/errors.h"

#include <algorithm>

namespace millsim {

std::string format_input_error(const InputError& error) {
  std::string text = error.path.empty() ? std::string("(top level)") : error.path;
  if (!error.value.empty()) text += " = " + error.value;
  text += ": " + error.allowed;
  return text;
}

std::string format_input_errors(const std::string& source, const InputErrors& errors) {
  std::string text = source + ": " + std::to_string(errors.size()) +
                     (errors.size() == 1 ? " error" : " errors") + "; nothing was run or written";
  const std::size_t shown = std::min(errors.size(), kMaxReportedErrors);
  for (std::size_t k = 0; k < shown; ++k) text += "\n  " + format_input_error(errors[k]);
  if (errors.size() > shown)
    text += "\n  ... and " + std::to_string(errors.size() - shown) + " more";
  return text;
}

InputErrorList::InputErrorList(InputErrors errors)
    : std::runtime_error(errors.empty() ? std::string("input error")
                                        : format_input_error(errors.front())),
      errors_(std::move(errors)) {}

}  // namespace millsim
