// A small reader for `--name value` options shared by the service verbs: each problem is
// reported once, naming the option, the value and what is allowed.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

namespace millsim::cli {

class ArgReader {
 public:
  ArgReader(std::string verb, const std::vector<std::string>& args)
      : verb_(std::move(verb)), args_(args) {}

  // Advances to the next argument; false at the end.
  bool next() {
    if (k_ + consumed_ >= args_.size()) return false;
    k_ += consumed_;
    consumed_ = 1;
    return true;
  }
  const std::string& current() const { return args_[k_]; }
  bool is_flag(const char* name) const { return current() == name; }

  bool option(const char* name, std::string& out) {
    if (current() != name) return false;
    if (k_ + 1 >= args_.size()) return fail(std::string(name) + " needs a value");
    out = args_[k_ + 1];
    consumed_ = 2;
    return true;
  }
  bool int_option(const char* name, int& out, long lo, long hi) {
    std::string text;
    if (!option(name, text)) return false;
    char* end = nullptr;
    const long v = std::strtol(text.c_str(), &end, 10);
    if (text.empty() || *end != '\0' || v < lo || v > hi)
      return fail(std::string(name) + " = " + text + ": expected an integer in [" +
                  std::to_string(lo) + ", " + std::to_string(hi) + "]");
    out = int(v);
    return true;
  }
  bool double_option(const char* name, double& out, double lo, double hi) {
    std::string text;
    if (!option(name, text)) return false;
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || *end != '\0' || !(v >= lo && v <= hi))
      return fail(std::string(name) + " = " + text + ": expected a number in [" +
                  std::to_string(lo) + ", " + std::to_string(hi) + "]");
    out = v;
    return true;
  }
  // The service token: `--token-file FILE` (its first line); `--token T` is refused, because
  // every user of the machine sees argv in ps. MILLSIM_TOKEN is read by the verb beforehand.
  bool token_option(std::string& token) {
    if (is_flag("--token"))
      return fail(
          "--token: give the token in MILLSIM_TOKEN or --token-file FILE; on the command "
          "line every user sees it in ps");
    std::string file;
    if (!option("--token-file", file)) return false;
    std::ifstream in(file);
    std::string line;
    std::getline(in, line);
    if (!in || line.empty())
      return fail("--token-file = " + file + ": cannot read a token from it");
    token = line;
    return true;
  }
  // A positional argument (the first non-option), or an error for a second one.
  bool positional(std::string& out) {
    if (!current().empty() && current()[0] == '-') return false;
    if (!out.empty()) return fail("unexpected argument \"" + current() + "\"");
    out = current();
    return true;
  }
  void unknown(const char* allowed) {
    fail("unknown option \"" + current() + "\"; allowed: " + allowed);
  }
  bool ok() const { return ok_; }
  // A problem found after the options were read (two that disagree).
  void error(const std::string& message) { fail(message); }

 private:
  bool fail(const std::string& message) {
    if (ok_) std::fprintf(stderr, "millsim %s: %s\n", verb_.c_str(), message.c_str());
    ok_ = false;
    return true;  // consumed: the caller moves on
  }
  std::string verb_;
  const std::vector<std::string>& args_;
  std::size_t k_ = 0, consumed_ = 0;
  bool ok_ = true;
};

}  // namespace millsim::cli
