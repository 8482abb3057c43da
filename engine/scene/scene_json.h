// Scene loading: JSON text → validated SceneConfig. All problems are collected (key path, value,
// what is allowed) and thrown together as InputErrorList; nothing is half-built.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/errors.h"
#include "core/json_reader.h"
#include "scene/scene_config.h"

namespace millsim {

// Reads and validates; throws InputErrorList (bad content) or IoError (unreadable file).
SceneConfig load_scene(const std::filesystem::path& path);

// Validates a parsed document; `base_dir` resolves relative particle-file paths.
SceneConfig parse_scene(const nlohmann::json& doc, const std::filesystem::path& base_dir,
                        InputErrors& errors);

// The index of the material named by `key` in `reader`'s object; reports an unknown name (and a
// missing one when `required`) and returns 0 then. Shared by the scene's sections.
int find_material(const std::vector<MaterialConfig>& materials, JsonObjectReader& reader,
                  std::string_view key, InputErrors& errors, bool required);

}  // namespace millsim
