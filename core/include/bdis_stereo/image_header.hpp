// What an encoded image says about itself before it is decoded: its format,
// size, channels and bit depth, and for JPEG and PNG whether the data is
// complete. So that an oversized, truncated or 16-bit image is refused before
// a decoder allocates for it (a 20000x20000 header in a 1 KB file) or quietly
// fills in what is missing (libjpeg decodes a truncated JPEG with a grey
// bottom and only a warning). Used by the tools on files and by the nodelet
// on sensor_msgs/CompressedImage data.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace bdis {

struct ImageHeader {
  enum class Format { Jpeg, Png, Bmp, Pnm };
  Format format = Format::Jpeg;
  int width = 0, height = 0;
  /// Channels as decoded to 8-bit: 1 (grey; a PNG's alpha dropped) or 3
  /// (colour; a palette expanded). 0 where the header does not tell (BMP, PNM).
  int channels = 0;
  /// Bits per sample: a JPEG's precision, a PNG's bit depth; 0 where not read.
  int bit_depth = 0;
};

/// "JPEG", "PNG", "BMP", "PNM".
const char* formatName(ImageHeader::Format format);

/// The format whose signature `data` starts with; false for none of the four.
bool detectImageFormat(const uint8_t* data, std::size_t size, ImageHeader::Format& format);

/// Reads the header of a JPEG (its frame header, SOFn), PNG (IHDR), BMP or
/// PNM (P1..P6) in `data`. For JPEG and PNG it also checks that the data is
/// complete: an end-of-image marker after the first scan, an IEND chunk.
/// Returns "" or what is wrong, as a predicate ("is a truncated JPEG (no
/// end-of-image marker)", "is not a JPEG, PNG, BMP or PNM image").
std::string readImageHeader(const uint8_t* data, std::size_t size, ImageHeader& header);

}  // namespace bdis
