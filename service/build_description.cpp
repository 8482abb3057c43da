#include <sys/utsname.h>

#include <fstream>
#include <string>

#include "build_info.h"
#include "sim/run.h"

namespace millsim {
namespace {

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) {
      const std::size_t colon = line.find(':');
      if (colon != std::string::npos) return line.substr(line.find_first_not_of(' ', colon + 1));
    }
  return "unknown";
}

}  // namespace

nlohmann::ordered_json build_description() {
  utsname u{};
  uname(&u);
  return {{"millsim_version", kMillsimVersion},
          {"git_commit", kGitCommit},
          {"compiler", kCompiler},
          {"machine", {{"host", u.nodename}, {"arch", u.machine}, {"cpu", cpu_model()}}}};
}

std::string build_fingerprint(const nlohmann::json& build) {
  if (!build.is_object()) return "";
  return build.value("git_commit", "") + "|" + build.value("compiler", "") + "|" +
         (build.contains("machine") ? build["machine"].dump() : "");
}

}  // namespace millsim
