// Fuzzes the scene loader: any bytes, as a scene file's text, are parsed and validated. The only
// outcomes allowed are a scene or a list of input errors (exit 2 in `millsim run`); a crash, a
// sanitizer report or another exception is a finding. Seeds: cases/*.json.
#include <cstddef>
#include <cstdint>

#include "core/errors.h"
#include "fuzz_json.h"
#include "scene/scene_json.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace millsim;
  const std::optional<nlohmann::json> doc = fuzz_input_as_json(data, size);
  if (!doc) return 0;  // not JSON: an input error
  InputErrors errors;
  // Files named by sources resolve in an empty folder of the working directory.
  const SceneConfig scene = parse_scene(*doc, "fuzz-empty", errors);
  (void)scene;
  return 0;
}
