// Test images whose header claims another size than their data: a tool that
// refuses them by that size read the header and decoded nothing.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

namespace bdis_test {

/// Rewrites the width and height in the header of the PNG, JPEG, BMP or PGM
/// file at `path` (as cv::imwrite writes them); the pixel data stays as it was.
inline void claimSize(const std::string& path, uint32_t width, uint32_t height) {
  std::vector<unsigned char> bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  ASSERT_GT(bytes.size(), 26u) << path;
  auto putBig = [&](std::size_t at, uint32_t v, int n) {
    for (int i = 0; i < n; ++i) bytes[at + i] = static_cast<unsigned char>(v >> (8 * (n - 1 - i)));
  };
  auto putLittle = [&](std::size_t at, uint32_t v) {
    for (int i = 0; i < 4; ++i) bytes[at + i] = static_cast<unsigned char>(v >> (8 * i));
  };
  if (bytes[0] == 0x89 && bytes[1] == 'P') {  // PNG: IHDR width, height
    putBig(16, width, 4);
    putBig(20, height, 4);
  } else if (bytes[0] == 0xFF && bytes[1] == 0xD8) {  // JPEG: the first frame header
    std::size_t at = 2;
    while (at + 9 < bytes.size()) {
      ASSERT_EQ(bytes[at], 0xFF) << path << ": no JPEG marker at " << at;
      const int marker = bytes[at + 1];
      if (marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC) {
        putBig(at + 5, height, 2);
        putBig(at + 7, width, 2);
        break;
      }
      at += 2 + (static_cast<std::size_t>(bytes[at + 2]) << 8 | bytes[at + 3]);
    }
    ASSERT_LT(at + 9, bytes.size()) << path << ": no JPEG frame header";
  } else if (bytes[0] == 'B' && bytes[1] == 'M') {  // BMP: BITMAPINFOHEADER width, height
    putLittle(18, width);
    putLittle(22, height);
  } else if (bytes[0] == 'P' && bytes[1] == '5') {  // PGM: "P5\nW H\nMAX\n" then the data
    std::istringstream header(std::string(bytes.begin(), bytes.end()));
    std::string magic;
    int old_width = 0, old_height = 0, max_value = 0;
    header >> magic >> old_width >> old_height >> max_value;
    const auto data_start = static_cast<std::size_t>(header.tellg()) + 1;
    const std::string new_header =
        "P5\n" + std::to_string(width) + " " + std::to_string(height) + "\n" + std::to_string(max_value) + "\n";
    std::vector<unsigned char> rewritten(new_header.begin(), new_header.end());
    rewritten.insert(rewritten.end(), bytes.begin() + static_cast<long>(data_start), bytes.end());
    bytes = rewritten;
  } else {
    FAIL() << path << ": not a PNG, JPEG, BMP or PGM file";
  }
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

}  // namespace bdis_test
