#pragma once
/// \file
/// Images from files for `red camera --from DIR` (docs/ROS2.md): PNG (libpng) and JPEG (libjpeg),
/// decoded to 8-bit RGB.

#include <cstdint>
#include <string>
#include <vector>

#include "red/core/expected.hpp"

namespace red::dds {

/// A decoded image: interleaved RGB, row-major.
struct RgbImage {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;
};

/// Decodes a PNG or JPEG file (by content, not name). Error names the file and the problem.
Expected<RgbImage> read_image(const std::string& path);

/// The PNG and JPEG files of `dir` (by extension .png, .jpg, .jpeg, any case), sorted by
/// name. Error when the directory cannot be read or holds none.
Expected<std::vector<std::string>> image_files(const std::string& dir);

}  // namespace red::dds
