#include "checkpoint/checkpoint_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "contact/contact_forces.h"
#include "core/errors.h"
#include "gas/coupling.h"
#include "io/input_file.h"
#include "search/neighbor_list.h"
#include "sim/simulation.h"

namespace millsim {
namespace {

constexpr char kMagic[8] = {'M', 'S', 'I', 'M', 'C', 'K', 'P', 'T'};
constexpr const char* kPrefix = "step-";
constexpr const char* kSuffix = ".ckpt";

void append_u64(std::string& out, std::uint64_t v) {
  out.append(reinterpret_cast<char*>(&v), 8);
}

std::string errno_text() {
  return std::strerror(errno);
}

// Writes all of `data` to `fd`, retrying short writes.
bool write_all(int fd, const std::string& data) {
  std::size_t done = 0;
  while (done < data.size()) {
    const ssize_t n = ::write(fd, data.data() + done, data.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += std::size_t(n);
  }
  return true;
}

// The step in "step-000000001234.ckpt", or -1 for another name.
long long step_of(const std::filesystem::path& p) {
  const std::string name = p.filename().string();
  const std::size_t prefix = std::strlen(kPrefix), suffix = std::strlen(kSuffix);
  if (name.size() <= prefix + suffix || name.compare(0, prefix, kPrefix) != 0 ||
      name.compare(name.size() - suffix, suffix, kSuffix) != 0)
    return -1;
  const std::string digits = name.substr(prefix, name.size() - prefix - suffix);
  if (digits.empty() || digits.size() > 18 ||
      !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return -1;
  return std::stoll(digits);
}

}  // namespace

std::uint64_t fnv1a64(const void* data, std::size_t n, std::uint64_t hash) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t k = 0; k < n; ++k) hash = (hash ^ p[k]) * 0x100000001b3ULL;
  return hash;
}

std::uint64_t checkpoint_layout() {
  const std::uint64_t sizes[] = {kCheckpointFormat,       sizeof(Vec3),
                                 sizeof(Motion),          sizeof(Load),
                                 sizeof(ParticleSprings), sizeof(ParticleId),
                                 sizeof(Newborn),         sizeof(NeighborSettings),
                                 sizeof(NeighborStats),   sizeof(GridDivision),
                                 sizeof(TimeStepInfo),    sizeof(ReducedStiffnessInfo),
                                 sizeof(Impact),          sizeof(StepProfile),
                                 sizeof(FluidCellState),  sizeof(CouplingStats),
                                 sizeof(GasStepStats),    sizeof(FeedStats),
                                 sizeof(BreakageEvent),   sizeof(ImpactGroup)};
  return fnv1a64(sizes, sizeof sizes);
}

std::uint64_t scene_hash(const std::string& scene_json_text) {
  const nlohmann::json scene = nlohmann::json::parse(scene_json_text, nullptr, false);
  const std::string canonical = scene.is_discarded() ? scene_json_text : scene.dump();
  return fnv1a64(canonical.data(), canonical.size());
}

void write_state_file(const std::filesystem::path& path, const CheckpointHeader& header,
                      const std::string& state) {
  const std::filesystem::path dir = path.parent_path().empty() ? "." : path.parent_path();
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw IoError("cannot create " + dir.string() + ": " + ec.message());
  ArchiveWriter h;
  CheckpointHeader copy = header;
  copy.checkpoint_io(h);
  // Written in three pieces, so the state (the bulk) is not copied once more.
  std::string head(kMagic, sizeof kMagic);
  const std::uint32_t format = kCheckpointFormat;
  head.append(reinterpret_cast<const char*>(&format), sizeof format);
  append_u64(head, h.data().size());
  head += h.data();
  append_u64(head, state.size());
  std::string tail;
  append_u64(tail, fnv1a64(state.data(), state.size(), fnv1a64(head.data(), head.size())));

  // A temporary name of this process's own, so two writers of one shared file never mix bytes.
  const std::filesystem::path temporary =
      dir / (path.filename().string() + "." + std::to_string(::getpid()) + ".tmp");
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw IoError("cannot write " + temporary.string() + ": " + errno_text());
  const bool written =
      write_all(fd, head) && write_all(fd, state) && write_all(fd, tail) && ::fsync(fd) == 0;
  const std::string why = errno_text();
  ::close(fd);
  if (!written) {
    std::filesystem::remove(temporary, ec);
    throw IoError("cannot write " + temporary.string() + ": " + why);
  }
  std::filesystem::rename(temporary, path, ec);
  if (ec) throw IoError("cannot rename " + temporary.string() + ": " + ec.message());
  if (const int dir_fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC); dir_fd >= 0) {
    ::fsync(dir_fd);  // the rename itself survives a crash
    ::close(dir_fd);
  }
}

std::filesystem::path write_checkpoint(const std::filesystem::path& dir,
                                       const CheckpointHeader& header, const std::string& state,
                                       int keep) {
  char name[64];
  std::snprintf(name, sizeof name, "%s%012lld%s", kPrefix, static_cast<long long>(header.step),
                kSuffix);
  const std::filesystem::path path = dir / name;
  write_state_file(path, header, state);
  std::error_code ec;
  const std::vector<std::filesystem::path> all = list_checkpoints(dir);
  for (std::size_t k = std::size_t(std::max(keep, 1)); k < all.size(); ++k)
    std::filesystem::remove(all[k], ec);
  return path;
}

Checkpoint read_checkpoint(const std::filesystem::path& path) {
  // A checkpoint is a regular file this program wrote: never a symlink, FIFO or device.
  std::string file;
  try {
    file = read_input_file(path, {{}, false});
  } catch (const InputFileRefused& e) {
    throw CheckpointError(std::string("refused: ") + e.what());
  } catch (const IoError& e) {
    throw CheckpointError(e.what());
  }
  const std::size_t fixed = sizeof kMagic + 4 + 8 + 8 + 8;
  if (file.size() < fixed)
    throw CheckpointError("it is truncated (" + std::to_string(file.size()) + " bytes)");
  if (std::memcmp(file.data(), kMagic, sizeof kMagic) != 0)
    throw CheckpointError("it is not a millsim checkpoint (no MSIMCKPT at its start)");
  std::uint64_t stored_sum;
  std::memcpy(&stored_sum, file.data() + file.size() - 8, 8);
  if (fnv1a64(file.data(), file.size() - 8) != stored_sum)
    throw CheckpointError("its checksum does not match: it is damaged or truncated");
  ArchiveReader r(file.data() + sizeof kMagic, file.size() - sizeof kMagic - 8);
  std::uint32_t format;
  r.bytes(&format, sizeof format);
  if (format != kCheckpointFormat)
    throw CheckpointError("its format is " + std::to_string(format) + "; this millsim reads " +
                          std::to_string(kCheckpointFormat));
  Checkpoint c;
  c.path = path;
  std::string header_bytes;
  io(r, header_bytes);
  ArchiveReader h(header_bytes.data(), header_bytes.size());
  c.header.checkpoint_io(h);
  io(r, c.state);
  if (!r.at_end()) throw CheckpointError("it has bytes after its state");
  return c;
}

std::vector<std::filesystem::path> list_checkpoints(const std::filesystem::path& dir) {
  std::vector<std::pair<long long, std::filesystem::path>> found;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec))
    if (const long long step = step_of(entry.path()); step >= 0)
      found.emplace_back(step, entry.path());
  std::sort(found.begin(), found.end(),
            [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<std::filesystem::path> paths;
  for (auto& f : found) paths.push_back(std::move(f.second));
  return paths;
}

void remove_checkpoints(const std::filesystem::path& dir) {
  std::error_code ec;
  for (const std::filesystem::path& p : list_checkpoints(dir)) std::filesystem::remove(p, ec);
  std::filesystem::remove(spin_up_checkpoint_path(dir), ec);
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec))
    if (entry.path().extension() == ".tmp") std::filesystem::remove(entry.path(), ec);
  std::filesystem::remove(dir, ec);  // only when empty
}

}  // namespace millsim
