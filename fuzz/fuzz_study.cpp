// Fuzzes the study parser as a server meets it: any bytes, as a POSTed study, are parsed and
// expanded into runs with the server's file rule (files_root). Allowed outcomes: a study, or
// InputErrorList; anything else (a crash, a sanitizer report, another exception) is a finding.
// Seeds: cases/*.study.json.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string_view>

#include "core/errors.h"
#include "core/json_reader.h"
#include "study.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace millsim;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  nlohmann::json spec;
  try {
    spec = parse_untrusted_json(text);
  } catch (const nlohmann::json::exception&) {
    return 0;
  } catch (const JsonTooDeep&) {
    return 0;
  }
  static const std::filesystem::path root = std::filesystem::absolute("fuzz-empty");
  try {
    const Study study = expand_study(spec, root, 200, &root);
    (void)study;
  } catch (const InputErrorList&) {
  }
  return 0;
}
