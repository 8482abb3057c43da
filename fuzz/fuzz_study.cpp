// Fuzzes the study parser as a server meets it: any bytes, as a POSTed study, are parsed and
// expanded into runs with the server's file rule (files_root). Allowed outcomes: a study, or
// InputErrorList; anything else (a crash, a sanitizer report, another exception) is a finding.
// Seeds: cases/*.study.json.
#include <cstddef>
#include <cstdint>
#include <filesystem>

#include "core/errors.h"
#include "fuzz_json.h"
#include "studies/study.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace millsim;
  const std::optional<nlohmann::json> spec = fuzz_input_as_json(data, size);
  if (!spec) return 0;  // not JSON: an input error
  static const std::filesystem::path root = std::filesystem::absolute("fuzz-empty");
  try {
    const Study study = expand_study(*spec, root, 200, &root);
    (void)study;
  } catch (const InputErrorList&) {
  }
  return 0;
}
