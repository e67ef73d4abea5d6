// Reads structured values from a fuzzer's bytes: every value is defined for
// every input (exhausted input gives zeros), so that mutations of the bytes
// move smoothly between values.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <initializer_list>
#include <string>

namespace hisfm {
namespace fuzz {

class FuzzInput {
 public:
  FuzzInput(const uint8_t* data, size_t size) : data_(data), size_(size) {}

  /// True once every byte is used.
  bool empty() const { return pos_ >= size_; }

  /// The next byte (0 when exhausted).
  uint8_t Byte() { return pos_ < size_ ? data_[pos_++] : 0; }

  /// The next 8 bytes as an integer (zero-padded).
  uint64_t Word() {
    uint64_t value = 0;
    for (int k = 0; k < 8; ++k)
      value |= static_cast<uint64_t>(Byte()) << (8 * k);
    return value;
  }

  /// An integer in [0, n) (n <= 256).
  int Below(int n) { return n <= 1 ? 0 : Byte() % n; }

  bool Bool() { return Byte() & 1; }

  /// One of `values`, or (last choice) any 64-bit integer.
  int64_t Pick(std::initializer_list<int64_t> values) {
    const int k = Below(static_cast<int>(values.size()) + 1);
    if (k == static_cast<int>(values.size()))
      return static_cast<int64_t>(Word());
    return *(values.begin() + k);
  }

  /// Up to `max` bytes (length first).
  std::string Bytes(size_t max) {
    size_t n = Byte();
    if (n > max) n = max;
    std::string out;
    for (size_t k = 0; k < n; ++k) out.push_back(static_cast<char>(Byte()));
    return out;
  }

 private:
  const uint8_t* data_;
  size_t size_;
  size_t pos_ = 0;
};

/// Splits `data` into `n` parts, each but the last preceded by its
/// little-endian 32-bit length (clamped to what is left): how the model
/// targets pack three files into one input.
inline void SplitFramed(const uint8_t* data, size_t size, int n,
                        std::string* parts) {
  size_t pos = 0;
  for (int k = 0; k < n; ++k) {
    if (k + 1 == n) {
      parts[k].assign(reinterpret_cast<const char*>(data) + pos, size - pos);
      return;
    }
    uint32_t length = 0;
    if (size - pos >= 4) {
      std::memcpy(&length, data + pos, 4);
      pos += 4;
    } else {
      pos = size;
    }
    if (length > size - pos) length = static_cast<uint32_t>(size - pos);
    parts[k].assign(reinterpret_cast<const char*>(data) + pos, length);
    pos += length;
  }
}

}  // namespace fuzz
}  // namespace hisfm
