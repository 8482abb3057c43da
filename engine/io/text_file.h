// Writing a text file so that it never appears half-written: the text goes to PATH.partial,
// which is renamed over PATH once complete (result.json, baselines, JUnit files).
#pragma once

#include <filesystem>
#include <string>

namespace millsim {

// Throws IoError when the file cannot be written or renamed into place.
void write_text_atomically(const std::filesystem::path& path, const std::string& text);

}  // namespace millsim
