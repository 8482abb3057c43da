// Binary archive of a run's state for checkpoints. Each stateful module lists its members once,
// in a member template `checkpoint_io(A& a)` that calls `io(a, member)` for each; the same list
// saves (ArchiveWriter) and restores (ArchiveReader), so the two cannot fall out of step.
//
// Encoding: trivially copyable values as their bytes (this build's layout: a checkpoint is read
// back by the same build, checkpoint_file.h checks the layout); vectors and strings as a
// 64-bit length then their elements; optionals as a flag byte then the value; the random
// generator as its standard text form. A reader never trusts a length: one that claims more
// bytes than are left is a CheckpointError, before anything is allocated.
#pragma once

#include <array>
#include <cstdint>
#include <cstring>
#include <optional>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace millsim {

struct CheckpointError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class ArchiveWriter {
 public:
  static constexpr bool kLoading = false;
  // An empty vector's data() may be null: nothing is copied for it.
  void bytes(void* data, std::size_t n) {
    if (n > 0) out_.append(static_cast<const char*>(data), n);
  }
  const std::string& data() const { return out_; }

 private:
  std::string out_;
};

class ArchiveReader {
 public:
  static constexpr bool kLoading = true;
  ArchiveReader(const char* data, std::size_t size) : at_(data), end_(data + size) {}
  void bytes(void* data, std::size_t n) {
    if (n == 0) return;  // memcpy takes no null pointer, even for 0 bytes
    need(n);
    std::memcpy(data, at_, n);
    at_ += n;
  }
  // Throws unless `n` more bytes are there.
  void need(std::size_t n) const {
    if (n > std::size_t(end_ - at_))
      throw CheckpointError("the state ends early (" + std::to_string(end_ - at_) +
                            " bytes left, " + std::to_string(n) + " needed)");
  }
  bool at_end() const { return at_ == end_; }

 private:
  const char* at_;
  const char* end_;
};

template <class T, class A>
concept CheckpointIo = requires(T& t, A& a) {
  t.checkpoint_io(a);
};

template <class A, class T>
void io(A& a, T& value);

template <class A, class T>
void io_elements(A& a, T* first, std::size_t n) {
  if constexpr (std::is_trivially_copyable_v<T> && !CheckpointIo<T, A>)
    a.bytes(first, n * sizeof(T));
  else
    for (std::size_t k = 0; k < n; ++k) io(a, first[k]);
}

template <class A>
std::uint64_t io_length(A& a, std::size_t length, std::size_t min_element_bytes) {
  std::uint64_t n = length;
  a.bytes(&n, sizeof n);
  if constexpr (A::kLoading) a.need(n * min_element_bytes);
  return n;
}

template <class A, class T>
void io(A& a, std::vector<T>& v) {
  static_assert(!std::is_same_v<T, bool>, "std::vector<bool> has no element bytes");
  constexpr std::size_t min_bytes = std::is_trivially_copyable_v<T> ? sizeof(T) : 1;
  const std::uint64_t n = io_length(a, v.size(), min_bytes);
  if constexpr (A::kLoading) v.resize(n);
  io_elements(a, v.data(), v.size());
}

template <class A>
void io(A& a, std::string& s) {
  const std::uint64_t n = io_length(a, s.size(), 1);
  if constexpr (A::kLoading) s.resize(n);
  a.bytes(s.data(), s.size());
}

template <class A, class T>
void io(A& a, std::optional<T>& o) {
  std::uint8_t has = o.has_value();
  a.bytes(&has, 1);
  if constexpr (A::kLoading) {
    if (has > 1) throw CheckpointError("an optional's flag is neither 0 nor 1");
    if (!has) return o.reset();
    if (!o) o.emplace();
  }
  if (has) io(a, *o);
}

template <class A, class T, std::size_t N>
void io(A& a, std::array<T, N>& v) {
  io_elements(a, v.data(), N);
}

// The Mersenne twister by its standard text form (its exact state, portable across builds).
template <class A>
void io(A& a, std::mt19937_64& rng) {
  std::string text;
  if constexpr (!A::kLoading) {
    std::ostringstream out;
    out << rng;
    text = out.str();
  }
  io(a, text);
  if constexpr (A::kLoading) {
    std::istringstream in(text);
    in >> rng;
    if (!in) throw CheckpointError("a random generator's state does not parse");
  }
}

template <class A, class T>
void io(A& a, T& value) {
  if constexpr (CheckpointIo<T, A>)
    value.checkpoint_io(a);
  else if constexpr (std::is_array_v<T>)
    io_elements(a, &value[0], std::extent_v<T>);
  else {
    static_assert(std::is_trivially_copyable_v<T>,
                  "give the type a checkpoint_io(A&) listing its members");
    a.bytes(&value, sizeof value);
  }
}

// io(a, x), io(a, y), ... in one call.
template <class A, class... T>
void io_all(A& a, T&... values) {
  (io(a, values), ...);
}

}  // namespace millsim
