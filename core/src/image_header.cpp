#include "bdis_stereo/image_header.hpp"

#include <cctype>
#include <cstring>
#include <limits>

namespace bdis {
namespace {

uint32_t bigEndian16(const uint8_t* p) { return (static_cast<uint32_t>(p[0]) << 8) | p[1]; }
uint32_t bigEndian32(const uint8_t* p) { return (bigEndian16(p) << 16) | bigEndian16(p + 2); }
uint32_t littleEndian16(const uint8_t* p) { return (static_cast<uint32_t>(p[1]) << 8) | p[0]; }
uint32_t littleEndian32(const uint8_t* p) { return (littleEndian16(p + 2) << 16) | littleEndian16(p); }

std::string sizeText(uint64_t width, uint64_t height) { return std::to_string(width) + "x" + std::to_string(height); }

bool fitsInt(uint64_t v) { return v <= static_cast<uint64_t>(std::numeric_limits<int>::max()); }

// JPEG: the markers from SOI up to the first scan (SOS), the frame header
// (SOFn) among them, then an EOI after the scan. 0xFF inside the entropy-coded
// data is always followed by 0x00 or a restart marker, so FF D9 there is EOI.
std::string readJpeg(const uint8_t* data, std::size_t size, ImageHeader& header) {
  header.format = ImageHeader::Format::Jpeg;
  bool have_frame = false;
  std::size_t pos = 2;  // after SOI
  for (;;) {
    if (pos >= size || data[pos] != 0xFF) return "is a corrupt JPEG (no marker where one must be)";
    while (pos < size && data[pos] == 0xFF) ++pos;  // fill bytes
    if (pos >= size) return "is a truncated JPEG (it ends inside its header)";
    const uint8_t marker = data[pos++];
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD8)) continue;  // no length
    if (marker == 0xD9) return "is a corrupt JPEG (it ends before its first scan)";
    if (pos + 2 > size) return "is a truncated JPEG (it ends inside its header)";
    const std::size_t length = bigEndian16(data + pos);
    if (length < 2 || pos + length > size) return "is a truncated JPEG (it ends inside its header)";
    // SOF0..SOF15 but DHT (C4), JPG (C8) and DAC (CC).
    const bool frame_header = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (frame_header) {
      if (length < 8) return "is a corrupt JPEG (its frame header is too short)";
      header.bit_depth = data[pos + 2];
      header.height = static_cast<int>(bigEndian16(data + pos + 3));
      header.width = static_cast<int>(bigEndian16(data + pos + 5));
      const int components = data[pos + 7];
      if (components != 1 && components != 3 && components != 4) {
        return "is a JPEG with " + std::to_string(components) + " components (1 grey, 3 colour or 4 CMYK expected)";
      }
      header.channels = components == 1 ? 1 : 3;
      have_frame = true;
    }
    if (marker == 0xDA) {  // start of scan: entropy-coded data follows
      if (!have_frame) return "is a corrupt JPEG (a scan before its frame header)";
      pos += length;
      break;
    }
    pos += length;
  }
  for (std::size_t i = size; i >= pos + 2; --i) {
    if (data[i - 2] == 0xFF && data[i - 1] == 0xD9) return "";
  }
  return "is a truncated JPEG (no end-of-image marker)";
}

// PNG: the signature, IHDR first, then chunks (length, type, data, CRC) up to IEND.
std::string readPng(const uint8_t* data, std::size_t size, ImageHeader& header) {
  header.format = ImageHeader::Format::Png;
  if (size < 8 + 25 || bigEndian32(data + 8) != 13 || std::memcmp(data + 12, "IHDR", 4) != 0) {
    return "is a corrupt or truncated PNG (no IHDR chunk)";
  }
  const uint64_t width = bigEndian32(data + 16), height = bigEndian32(data + 20);
  if (!fitsInt(width) || !fitsInt(height)) return "is a corrupt PNG (size " + sizeText(width, height) + ")";
  header.width = static_cast<int>(width);
  header.height = static_cast<int>(height);
  header.bit_depth = data[24];
  switch (data[25]) {  // colour type
    case 0:  // grey
    case 4:  // grey and alpha
      header.channels = 1;
      break;
    case 2:  // RGB
    case 3:  // palette
    case 6:  // RGBA
      header.channels = 3;
      break;
    default:
      return "is a corrupt PNG (colour type " + std::to_string(data[25]) + ")";
  }
  std::size_t pos = 8;
  while (pos + 12 <= size) {
    const uint64_t length = bigEndian32(data + pos);
    if (std::memcmp(data + pos + 4, "IEND", 4) == 0) return "";
    pos += 12 + length;
  }
  return "is a truncated PNG (no IEND chunk)";
}

// BMP: the file header (14 bytes), then the size in the info header:
// 16-bit in BITMAPCOREHEADER (12 bytes), else signed 32-bit with a negative
// height for top-down rows.
std::string readBmp(const uint8_t* data, std::size_t size, ImageHeader& header) {
  header.format = ImageHeader::Format::Bmp;
  if (size < 26) return "is a truncated BMP (it ends inside its header)";
  if (littleEndian32(data + 14) == 12) {
    header.width = static_cast<int>(littleEndian16(data + 18));
    header.height = static_cast<int>(littleEndian16(data + 20));
    return "";
  }
  const auto width = static_cast<int32_t>(littleEndian32(data + 18));
  const auto height = static_cast<int32_t>(littleEndian32(data + 22));
  if (width <= 0 || height == std::numeric_limits<int32_t>::min()) {
    return "is a corrupt BMP (size " + std::to_string(width) + "x" + std::to_string(height) + ")";
  }
  header.width = width;
  header.height = height < 0 ? -height : height;
  return "";
}

// PNM (P1..P6): the magic, then width and height as text, '#' comments between.
std::string readPnm(const uint8_t* data, std::size_t size, ImageHeader& header) {
  header.format = ImageHeader::Format::Pnm;
  std::size_t pos = 2;
  uint64_t values[2] = {0, 0};
  for (uint64_t& value : values) {
    while (pos < size && (std::isspace(data[pos]) || data[pos] == '#')) {
      if (data[pos] == '#') {
        while (pos < size && data[pos] != '\n') ++pos;
      } else {
        ++pos;
      }
    }
    if (pos >= size || !std::isdigit(data[pos])) return "is a corrupt or truncated PNM (no size in its header)";
    while (pos < size && std::isdigit(data[pos])) {
      value = value * 10 + static_cast<uint64_t>(data[pos++] - '0');
      if (!fitsInt(value)) return "is a corrupt PNM (a size above 2^31)";
    }
  }
  header.width = static_cast<int>(values[0]);
  header.height = static_cast<int>(values[1]);
  return "";
}

}  // namespace

const char* formatName(ImageHeader::Format format) {
  switch (format) {
    case ImageHeader::Format::Jpeg:
      return "JPEG";
    case ImageHeader::Format::Png:
      return "PNG";
    case ImageHeader::Format::Bmp:
      return "BMP";
    case ImageHeader::Format::Pnm:
      return "PNM";
  }
  return "?";
}

bool detectImageFormat(const uint8_t* data, std::size_t size, ImageHeader::Format& format) {
  static const uint8_t kPngSignature[8] = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
  using Format = ImageHeader::Format;
  if (size >= 2 && data[0] == 0xFF && data[1] == 0xD8) {
    format = Format::Jpeg;
  } else if (size >= 8 && std::memcmp(data, kPngSignature, 8) == 0) {
    format = Format::Png;
  } else if (size >= 2 && data[0] == 'B' && data[1] == 'M') {
    format = Format::Bmp;
  } else if (size >= 2 && data[0] == 'P' && data[1] >= '1' && data[1] <= '6') {
    format = Format::Pnm;
  } else {
    return false;
  }
  return true;
}

std::string readImageHeader(const uint8_t* data, std::size_t size, ImageHeader& header) {
  header = ImageHeader();
  if (size == 0) return "is empty";
  ImageHeader::Format format;
  if (!detectImageFormat(data, size, format)) return "is not a JPEG, PNG, BMP or PNM image";
  switch (format) {
    case ImageHeader::Format::Jpeg:
      return readJpeg(data, size, header);
    case ImageHeader::Format::Png:
      return readPng(data, size, header);
    case ImageHeader::Format::Bmp:
      return readBmp(data, size, header);
    case ImageHeader::Format::Pnm:
      return readPnm(data, size, header);
  }
  return "is not a JPEG, PNG, BMP or PNM image";
}

}  // namespace bdis
