// Renders a report in headless Chromium, as a person would look at it, and
// checks the screenshot: the right size, many colours, the stage bars and
// the community colours visible. Skipped (with a message) when Chromium is
// not installed (Debian package `chromium`, installed by scripts/setup.sh).
#include <gtest/gtest.h>

#include <array>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <stdexcept>

#include "hisfm/report/report_test_util.h"
#include "hisfm/report/report_writer.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/test_util.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace {

// ---------------------------------------------------------------------------
// A small PNG decoder for the screenshot: DEFLATE (RFC 1951) inside zlib
// (RFC 1950), then PNG's per-row filters (8-bit RGB or RGBA, no interlace).

class BitStream {
 public:
  BitStream(const uint8_t* data, size_t size) : data_(data), size_(size) {}
  uint32_t Bits(int n) {
    uint32_t value = bit_buffer_;
    while (bit_count_ < n) {
      if (pos_ >= size_) throw std::runtime_error("deflate: out of input");
      value |= static_cast<uint32_t>(data_[pos_++]) << bit_count_;
      bit_count_ += 8;
    }
    bit_buffer_ = n == 32 ? 0 : value >> n;
    bit_count_ -= n;
    return n == 32 ? value : value & ((1u << n) - 1);
  }
  void AlignToByte() {
    bit_buffer_ = 0;
    bit_count_ = 0;
  }
  uint8_t Byte() {
    if (pos_ >= size_) throw std::runtime_error("deflate: out of input");
    return data_[pos_++];
  }

 private:
  const uint8_t* data_;
  size_t size_;
  size_t pos_ = 0;
  uint32_t bit_buffer_ = 0;
  int bit_count_ = 0;
};

// Canonical Huffman code: number of codes per length, symbols by code.
struct Huffman {
  std::array<int, 16> count{};
  std::vector<int> symbols;

  explicit Huffman(const std::vector<int>& lengths) {
    for (int l : lengths) ++count[l];
    count[0] = 0;
    std::array<int, 16> offset{};
    for (int l = 1; l < 16; ++l) offset[l] = offset[l - 1] + count[l - 1];
    symbols.assign(lengths.size(), 0);
    for (size_t s = 0; s < lengths.size(); ++s) {
      if (lengths[s] != 0) symbols[offset[lengths[s]]++] = static_cast<int>(s);
    }
  }
  // Reads one symbol: codes are read most significant bit first.
  int Decode(BitStream& in) const {
    int code = 0, first = 0, index = 0;
    for (int l = 1; l < 16; ++l) {
      code |= static_cast<int>(in.Bits(1));
      const int n = count[l];
      if (code - first < n) return symbols[index + code - first];
      index += n;
      first = (first + n) << 1;
      code <<= 1;
    }
    throw std::runtime_error("deflate: bad code");
  }
};

std::vector<uint8_t> Inflate(const uint8_t* data, size_t size) {
  static const int kLengthBase[29] = {3,  4,  5,  6,   7,   8,   9,   10,
                                      11, 13, 15, 17,  19,  23,  27,  31,
                                      35, 43, 51, 59,  67,  83,  99,  115,
                                      131, 163, 195, 227, 258};
  static const int kLengthExtra[29] = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1,
                                       1, 1, 2, 2, 2, 2, 3, 3, 3, 3,
                                       4, 4, 4, 4, 5, 5, 5, 5, 0};
  static const int kDistBase[30] = {
      1,    2,    3,    4,    5,    7,     9,     13,    17,  25,
      33,   49,   65,   97,   129,  193,   257,   385,   513, 769,
      1025, 1537, 2049, 3073, 4097, 6145,  8193,  12289, 16385, 24577};
  static const int kDistExtra[30] = {0, 0, 0, 0, 1, 1, 2, 2,  3,  3,
                                     4, 4, 5, 5, 6, 6, 7, 7,  8,  8,
                                     9, 9, 10, 10, 11, 11, 12, 12, 13, 13};
  BitStream in(data, size);
  std::vector<uint8_t> out;
  bool last = false;
  while (!last) {
    last = in.Bits(1) != 0;
    const uint32_t type = in.Bits(2);
    if (type == 0) {
      in.AlignToByte();
      const uint32_t len = in.Byte() | (in.Byte() << 8);
      in.Byte();
      in.Byte();
      for (uint32_t i = 0; i < len; ++i) out.push_back(in.Byte());
      continue;
    }
    std::vector<int> lit_lengths, dist_lengths;
    if (type == 1) {
      lit_lengths.assign(288, 8);
      for (int s = 144; s < 256; ++s) lit_lengths[s] = 9;
      for (int s = 256; s < 280; ++s) lit_lengths[s] = 7;
      dist_lengths.assign(30, 5);
    } else if (type == 2) {
      const int num_lit = static_cast<int>(in.Bits(5)) + 257;
      const int num_dist = static_cast<int>(in.Bits(5)) + 1;
      const int num_code = static_cast<int>(in.Bits(4)) + 4;
      static const int kOrder[19] = {16, 17, 18, 0, 8,  7, 9,  6, 10, 5,
                                     11, 4,  12, 3, 13, 2, 14, 1, 15};
      std::vector<int> code_lengths(19, 0);
      for (int i = 0; i < num_code; ++i) {
        code_lengths[kOrder[i]] = static_cast<int>(in.Bits(3));
      }
      const Huffman code_huffman(code_lengths);
      std::vector<int> lengths;
      while (static_cast<int>(lengths.size()) < num_lit + num_dist) {
        const int sym = code_huffman.Decode(in);
        if (sym < 16) {
          lengths.push_back(sym);
        } else if (sym == 16) {
          if (lengths.empty()) throw std::runtime_error("deflate: repeat");
          const int prev = lengths.back();
          for (int r = 3 + static_cast<int>(in.Bits(2)); r > 0; --r) {
            lengths.push_back(prev);
          }
        } else {
          const int zeros = sym == 17 ? 3 + static_cast<int>(in.Bits(3))
                                      : 11 + static_cast<int>(in.Bits(7));
          lengths.insert(lengths.end(), zeros, 0);
        }
      }
      lit_lengths.assign(lengths.begin(), lengths.begin() + num_lit);
      dist_lengths.assign(lengths.begin() + num_lit, lengths.end());
    } else {
      throw std::runtime_error("deflate: bad block type");
    }
    const Huffman lit(lit_lengths), dist(dist_lengths);
    while (true) {
      const int sym = lit.Decode(in);
      if (sym < 256) {
        out.push_back(static_cast<uint8_t>(sym));
        continue;
      }
      if (sym == 256) break;
      const int l = sym - 257;
      if (l >= 29) throw std::runtime_error("deflate: bad length");
      const int length =
          kLengthBase[l] + static_cast<int>(in.Bits(kLengthExtra[l]));
      const int d = dist.Decode(in);
      if (d >= 30) throw std::runtime_error("deflate: bad distance");
      const size_t distance =
          kDistBase[d] + static_cast<size_t>(in.Bits(kDistExtra[d]));
      if (distance > out.size()) throw std::runtime_error("deflate: far");
      for (int i = 0; i < length; ++i) out.push_back(out[out.size() - distance]);
    }
  }
  return out;
}

struct RgbImage {
  int width = 0, height = 0;
  std::vector<std::array<uint8_t, 3>> pixels;
};

uint32_t ReadBe32(const std::string& s, size_t pos) {
  return (uint32_t{static_cast<uint8_t>(s[pos])} << 24) |
         (uint32_t{static_cast<uint8_t>(s[pos + 1])} << 16) |
         (uint32_t{static_cast<uint8_t>(s[pos + 2])} << 8) |
         uint32_t{static_cast<uint8_t>(s[pos + 3])};
}

RgbImage DecodePng(const std::string& file) {
  if (file.compare(0, 8, "\x89PNG\r\n\x1a\n") != 0) {
    throw std::runtime_error("not a PNG");
  }
  RgbImage image;
  int color_type = -1;
  std::string idat;
  for (size_t pos = 8; pos + 8 <= file.size();) {
    const uint32_t length = ReadBe32(file, pos);
    const std::string type = file.substr(pos + 4, 4);
    if (type == "IHDR") {
      image.width = static_cast<int>(ReadBe32(file, pos + 8));
      image.height = static_cast<int>(ReadBe32(file, pos + 12));
      if (file[pos + 16] != 8 || file[pos + 20] != 0) {
        throw std::runtime_error("PNG: only 8-bit, non-interlaced");
      }
      color_type = file[pos + 17];
    } else if (type == "IDAT") {
      idat += file.substr(pos + 8, length);
    }
    pos += 12 + length;
  }
  if (color_type != 2 && color_type != 6) {
    throw std::runtime_error("PNG: only RGB or RGBA");
  }
  const int bpp = color_type == 6 ? 4 : 3;
  const std::vector<uint8_t> raw = Inflate(
      reinterpret_cast<const uint8_t*>(idat.data()) + 2, idat.size() - 2);
  const size_t stride = static_cast<size_t>(image.width) * bpp;
  if (raw.size() < (stride + 1) * image.height) {
    throw std::runtime_error("PNG: short image data");
  }
  std::vector<uint8_t> prev(stride, 0), row(stride);
  image.pixels.reserve(static_cast<size_t>(image.width) * image.height);
  for (int y = 0; y < image.height; ++y) {
    const uint8_t* src = raw.data() + y * (stride + 1);
    const int filter = src[0];
    for (size_t i = 0; i < stride; ++i) {
      const int a = i >= static_cast<size_t>(bpp) ? row[i - bpp] : 0;
      const int b = prev[i];
      const int c = i >= static_cast<size_t>(bpp) ? prev[i - bpp] : 0;
      int predictor = 0;
      switch (filter) {
        case 1: predictor = a; break;
        case 2: predictor = b; break;
        case 3: predictor = (a + b) / 2; break;
        case 4: {
          const int p = a + b - c;
          const int pa = std::abs(p - a), pb = std::abs(p - b),
                    pc = std::abs(p - c);
          predictor = pa <= pb && pa <= pc ? a : (pb <= pc ? b : c);
          break;
        }
        default: break;
      }
      row[i] = static_cast<uint8_t>(src[1 + i] + predictor);
    }
    for (int x = 0; x < image.width; ++x) {
      image.pixels.push_back({row[x * bpp], row[x * bpp + 1],
                              row[x * bpp + 2]});
    }
    std::swap(prev, row);
  }
  return image;
}

// The Chromium executable, or "" if none is installed.
std::string FindChromium() {
  if (const char* env = std::getenv("HISFM_CHROMIUM")) return env;
  for (const char* name : {"chromium", "chromium-browser", "google-chrome"}) {
    if (RunShell(StrCat("command -v ", name, " >/dev/null 2>&1")) == 0) {
      return name;
    }
  }
  return "";
}

size_t CountNear(const RgbImage& image, std::array<int, 3> color,
                 int tolerance) {
  size_t n = 0;
  for (const auto& p : image.pixels) {
    if (std::abs(p[0] - color[0]) <= tolerance &&
        std::abs(p[1] - color[1]) <= tolerance &&
        std::abs(p[2] - color[2]) <= tolerance) {
      ++n;
    }
  }
  return n;
}

TEST(PngDecoder, DecodesAKnownStoredImage) {
  // 2x1 RGB image, filter 0, stored (uncompressed) deflate block.
  const std::string raw = std::string("\x00\xff\x00\x00\x00\x00\xff", 7);
  std::string z = "\x78\x01";
  z += '\x01';  // Final stored block.
  z += static_cast<char>(raw.size());
  z += '\0';
  z += static_cast<char>(~raw.size() & 0xFF);
  z += '\xff';
  z += raw;
  z += std::string(4, '\0');  // Adler-32 (not checked).
  auto be32 = [](uint32_t v) {
    return std::string{static_cast<char>(v >> 24), static_cast<char>(v >> 16),
                       static_cast<char>(v >> 8), static_cast<char>(v)};
  };
  const std::string png = std::string("\x89PNG\r\n\x1a\n", 8) + be32(13) +
                          "IHDR" + be32(2) + be32(1) +
                          std::string("\x08\x02\x00\x00\x00", 5) + be32(0) +
                          be32(static_cast<uint32_t>(z.size())) + "IDAT" + z +
                          be32(0) + be32(0) + "IEND" + be32(0);
  const RgbImage image = DecodePng(png);
  ASSERT_EQ(image.width, 2);
  ASSERT_EQ(image.pixels.size(), 2u);
  EXPECT_EQ(image.pixels[0], (std::array<uint8_t, 3>{255, 0, 0}));
  EXPECT_EQ(image.pixels[1], (std::array<uint8_t, 3>{0, 0, 255}));
}

TEST(ReportRender, ChromiumShowsTheDrawings) {
  const std::string chromium = FindChromium();
  if (chromium.empty()) {
    GTEST_SKIP() << "chromium not installed (apt-get install chromium); "
                    "the report was not rendered";
  }
  TempDir tmp("hisfm-render");
  ReportInput in;
  in.title = "Render test";
  in.model = testing_scene::RingModel(24, 4000, 5.0);
  nlohmann::json images = nlohmann::json::array();
  nlohmann::json bridges = nlohmann::json::array();
  for (const auto& [id, image] : in.model->images) {
    images.push_back({{"image_id", id},
                      {"name", image.name},
                      {"community", static_cast<int>(id - 1) / 6},
                      {"skeletal", true}});
  }
  for (int c = 0; c < 3; ++c) {
    bridges.push_back({{"image_id1", 6 * c + 6}, {"image_id2", 6 * c + 7},
                       {"community1", c}, {"community2", c + 1},
                       {"inliers", 80}, {"score", 0.9}});
  }
  in.hierarchy = {{"images", images},
                  {"num_communities", 4},
                  {"skeleton_bridges", bridges},
                  {"rejected_bridges",
                   nlohmann::json::array({{{"image_id1", 1},
                                           {"image_id2", 13},
                                           {"inliers", 100},
                                           {"score", 0.05}}})}};
  in.stages = {{"feature extraction", 20, ""}, {"matching", 60, ""}};
  const std::string html_path = tmp / "report.html";
  WriteReport(in, html_path);

  const std::string png_path = tmp / "shot.png";
  const std::string command = StrCat(
      "timeout 120 ", chromium,
      " --headless --no-sandbox --disable-gpu --disable-quic --no-first-run"
      " --disable-background-networking --disable-component-update"
      " --disable-sync --hide-scrollbars"
      // Let layout and paint finish before the screenshot is taken; without
      // it a loaded machine sometimes captures the page half painted.
      " --run-all-compositor-stages-before-draw --virtual-time-budget=5000"
      " --user-data-dir=",
      tmp.path(), "/profile --screenshot=", png_path,
      " --window-size=1400,2400 file://", html_path);
  ASSERT_EQ(RunShell(command, tmp / "chromium.log"), 0)
      << ReadTextFile(tmp / "chromium.log");
  ASSERT_TRUE(fs::exists(png_path)) << ReadTextFile(tmp / "chromium.log");
  EXPECT_GT(fs::file_size(png_path), 50u * 1024u);

  const RgbImage shot = DecodePng(ReadTextFile(png_path));
  ASSERT_EQ(shot.width, 1400);
  ASSERT_EQ(shot.height, 2400);
  std::map<uint32_t, size_t> histogram;
  for (const auto& p : shot.pixels) {
    ++histogram[(uint32_t{p[0]} << 16) | (uint32_t{p[1]} << 8) | p[2]];
  }
  size_t most = 0;
  for (const auto& [color, n] : histogram) most = std::max(most, n);
  EXPECT_GT(histogram.size(), 200u) << "a nearly single-colour screenshot";
  EXPECT_LT(most, shot.pixels.size() * 9 / 10);
  // The stage bars (#5b7bd5), the first community's colour
  // (hsl(0,70%,45%) = #c32222) and the red of rejected bridges (#d62728).
  EXPECT_GT(CountNear(shot, {0x5b, 0x7b, 0xd5}, 2), 2000u);
  EXPECT_GT(CountNear(shot, {0xc3, 0x22, 0x22}, 6), 100u);
  EXPECT_GT(CountNear(shot, {0xd6, 0x27, 0x28}, 30), 20u);
}

}  // namespace
}  // namespace hisfm
