// readImageHeader: the size, channels and depth of encoded images as OpenCV
// writes them, read without decoding, and what is wrong with broken ones.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "bdis_stereo/image_header.hpp"

namespace {

using bdis::ImageHeader;
using Format = ImageHeader::Format;

std::vector<uint8_t> encode(const cv::Mat& image, const std::string& ext) {
  std::vector<uint8_t> data;
  EXPECT_TRUE(cv::imencode(ext, image, data));
  return data;
}

cv::Mat noise(int rows, int cols, int type) {
  cv::Mat m(rows, cols, type);
  cv::randu(m, 0, 256);
  return m;
}

std::string read(const std::vector<uint8_t>& data, ImageHeader& h) {
  return bdis::readImageHeader(data.data(), data.size(), h);
}

TEST(ImageHeader, ReadsEachFormatAsWritten) {
  ImageHeader h;
  ASSERT_EQ(read(encode(noise(48, 64, CV_8UC1), ".jpg"), h), "");
  EXPECT_EQ(std::make_tuple(h.format, h.width, h.height, h.channels, h.bit_depth),
            std::make_tuple(Format::Jpeg, 64, 48, 1, 8));
  ASSERT_EQ(read(encode(noise(48, 64, CV_8UC3), ".jpg"), h), "");
  EXPECT_EQ(h.channels, 3);
  ASSERT_EQ(read(encode(noise(36, 40, CV_8UC4), ".png"), h), "");  // alpha dropped when decoded
  EXPECT_EQ(std::make_tuple(h.format, h.width, h.height, h.channels, h.bit_depth),
            std::make_tuple(Format::Png, 40, 36, 3, 8));
  ASSERT_EQ(read(encode(cv::Mat(36, 40, CV_16UC1, cv::Scalar(1000)), ".png"), h), "");
  EXPECT_EQ(std::make_tuple(h.channels, h.bit_depth), std::make_tuple(1, 16));
  ASSERT_EQ(read(encode(noise(30, 50, CV_8UC3), ".bmp"), h), "");
  EXPECT_EQ(std::make_tuple(h.format, h.width, h.height), std::make_tuple(Format::Bmp, 50, 30));
  ASSERT_EQ(read(encode(noise(30, 50, CV_8UC1), ".pgm"), h), "");
  EXPECT_EQ(std::make_tuple(h.format, h.width, h.height), std::make_tuple(Format::Pnm, 50, 30));
  EXPECT_STREQ(bdis::formatName(Format::Png), "PNG");
}

// What a decoder would not say (libjpeg decodes a truncated JPEG with a grey
// bottom and a warning) or would only find out after allocating.
TEST(ImageHeader, BrokenDataIsNamed) {
  ImageHeader h;
  const std::vector<uint8_t> jpeg = encode(noise(48, 64, CV_8UC1), ".jpg");
  std::vector<uint8_t> cut(jpeg.begin(), jpeg.begin() + jpeg.size() / 2);
  EXPECT_EQ(read(cut, h), "is a truncated JPEG (no end-of-image marker)");
  cut.assign(jpeg.begin(), jpeg.begin() + 40);
  EXPECT_EQ(read(cut, h), "is a truncated JPEG (it ends inside its header)");
  const std::vector<uint8_t> png = encode(noise(48, 64, CV_8UC3), ".png");
  cut.assign(png.begin(), png.end() - 12);  // without IEND
  EXPECT_EQ(read(cut, h), "is a truncated PNG (no IEND chunk)");
  cut.assign(png.begin(), png.begin() + 20);
  EXPECT_EQ(read(cut, h), "is a corrupt or truncated PNG (no IHDR chunk)");
  EXPECT_EQ(read({}, h), "is empty");
  const std::vector<uint8_t> text = {'h', 'e', 'l', 'l', 'o'};
  EXPECT_EQ(read(text, h), "is not a JPEG, PNG, BMP or PNM image");
  Format f;
  EXPECT_FALSE(bdis::detectImageFormat(text.data(), text.size(), f));
  ASSERT_TRUE(bdis::detectImageFormat(png.data(), png.size(), f));
  EXPECT_EQ(f, Format::Png);
  const std::vector<uint8_t> pnm_without_size = {'P', '5', '\n', '#', ' ', 'x', '\n'};
  EXPECT_EQ(read(pnm_without_size, h), "is a corrupt or truncated PNM (no size in its header)");
}

// The size comes from the header alone: a 64x48 PNG whose IHDR claims
// 20000x20000 reads as 20000x20000 (what lets the tools refuse it unread).
TEST(ImageHeader, SizeIsTheHeadersClaim) {
  std::vector<uint8_t> png = encode(noise(48, 64, CV_8UC1), ".png");
  for (int i : {16, 20}) {  // IHDR width, height (big-endian)
    png[i] = 0, png[i + 1] = 0, png[i + 2] = 0x4E, png[i + 3] = 0x20;
  }
  ImageHeader h;
  ASSERT_EQ(read(png, h), "");
  EXPECT_EQ(std::make_tuple(h.width, h.height), std::make_tuple(20000, 20000));
}

// Every prefix of a valid file, and every early byte overwritten: a verdict
// from the bytes given (exact-size buffers, so the sanitizer build catches a
// read past the end), a truncated JPEG or PNG always named as broken.
TEST(ImageHeader, EveryPrefixAndEveryEarlyByteGetAVerdict) {
  const std::vector<std::pair<std::string, cv::Mat>> files = {
      {".jpg", noise(20, 24, CV_8UC3)}, {".png", noise(20, 24, CV_8UC1)},
      {".bmp", noise(20, 24, CV_8UC3)}, {".pgm", noise(20, 24, CV_8UC1)}};
  for (const auto& [ext, image] : files) {
    const std::vector<uint8_t> data = encode(image, ext);
    const bool checks_completeness = ext == ".jpg" || ext == ".png";
    for (std::size_t n = 0; n < data.size(); ++n) {
      const std::vector<uint8_t> cut(data.begin(), data.begin() + static_cast<std::ptrdiff_t>(n));
      ImageHeader h;
      const std::string verdict = read(cut, h);
      if (checks_completeness) {
        EXPECT_FALSE(verdict.empty()) << ext << " cut to " << n << " bytes";
      }
      EXPECT_TRUE(verdict.empty() || verdict.rfind("is ", 0) == 0) << verdict;
    }
    for (std::size_t i = 0; i < std::min<std::size_t>(data.size(), 160); ++i) {
      for (const uint8_t value : {uint8_t{0x00}, uint8_t{0xFF}, static_cast<uint8_t>(data[i] ^ 0x5A)}) {
        std::vector<uint8_t> bad = data;
        bad[i] = value;
        ImageHeader h;
        const std::string verdict = read(bad, h);
        EXPECT_TRUE(verdict.empty() || verdict.rfind("is ", 0) == 0) << verdict;
        if (verdict.empty()) {
          EXPECT_TRUE(h.width >= 0 && h.height >= 0) << ext << " byte " << i;
        }
      }
    }
  }
}

}  // namespace
