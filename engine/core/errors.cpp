#include "core/errors.h"

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
  for (const InputError& e : errors) text += "\n  " + format_input_error(e);
  return text;
}

InputErrorList::InputErrorList(InputErrors errors)
    : std::runtime_error(errors.empty() ? std::string("input error")
                                        : format_input_error(errors.front())),
      errors_(std::move(errors)) {}

}  // namespace millsim
