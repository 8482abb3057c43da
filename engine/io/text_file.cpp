#include "io/text_file.h"

#include <fstream>

#include "core/errors.h"

namespace millsim {

void write_text_atomically(const std::filesystem::path& path, const std::string& text) {
  const std::filesystem::path partial = path.string() + ".partial";
  {
    std::ofstream out(partial, std::ios::trunc);
    out << text;
    out.flush();
    if (!out) throw IoError("cannot write " + partial.string());
  }
  std::error_code ec;
  std::filesystem::rename(partial, path, ec);
  if (ec) throw IoError("cannot write " + path.string() + ": " + ec.message());
}

}  // namespace millsim
