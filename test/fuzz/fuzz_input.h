// Sequential little-endian reader over a libFuzzer input: the seed generator
// (test/fuzz/make_seed_corpus.py) writes the same layouts, so a seed decodes to the object,
// cloud or path it was made from. Reads past the end give zeros (the fuzzer shortens inputs
// freely; a short input must still decode to something).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

namespace fast_grasp
{
namespace fuzz
{
class FuzzInput
{
public:
  FuzzInput(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  template <typename T>
  T read()
  {
    T value{};
    const std::size_t n = std::min(sizeof(T), remaining());
    if (n > 0)
      std::memcpy(&value, data_ + offset_, n);
    offset_ += n;
    return value;
  }

  /// A float that may hold any bit pattern (NaN, inf, denormal) when `raw`, else a coordinate
  /// in [-3.2768, 3.2767] m with 0.1 mm steps (what a real cloud holds).
  float coordinate(bool raw) { return raw ? read<float>() : read<std::int16_t>() * 1e-4f; }

  std::size_t remaining() const { return offset_ < size_ ? size_ - offset_ : 0; }
  const std::uint8_t* rest() const { return data_ + std::min(offset_, size_); }
  std::string restAsString() const { return std::string(reinterpret_cast<const char*>(rest()), remaining()); }

private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t offset_ = 0;
};

/// A file holding `bytes`, for the loaders that only take a path (yaml-cpp, PCL's readers).
/// One per process: libFuzzer runs inputs one after the other.
std::string writeTempFile(const std::string& bytes, const std::string& extension);

}  // namespace fuzz
}  // namespace fast_grasp
