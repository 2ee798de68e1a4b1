// Images from files for `red camera --from DIR`: PNG and JPEG decode to RGB; bad files and
// empty directories give located errors; the camera publishes them to a node.

#include <gtest/gtest.h>

// clang-format off
#include <cstdio>
#include <jpeglib.h>
// clang-format on
#include <png.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "../support/cli.hpp"
#include "red/dds/image_files.hpp"
#include "support.hpp"

namespace red::dds {
namespace {

namespace fs = std::filesystem;

std::vector<std::uint8_t> pattern(int w, int h) {
  std::vector<std::uint8_t> rgb(static_cast<std::size_t>(w * h * 3));
  for (std::size_t i = 0; i < rgb.size(); ++i) rgb[i] = static_cast<std::uint8_t>((i * 13) % 256);
  return rgb;
}

void write_png(const std::string& path, int w, int h) {
  png_image img{};
  img.version = PNG_IMAGE_VERSION;
  img.width = static_cast<png_uint_32>(w);
  img.height = static_cast<png_uint_32>(h);
  img.format = PNG_FORMAT_RGB;
  const auto rgb = pattern(w, h);
  ASSERT_NE(png_image_write_to_file(&img, path.c_str(), 0, rgb.data(), 0, nullptr), 0);
}

void write_jpeg(const std::string& path, int w, int h) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  ASSERT_NE(f, nullptr);
  jpeg_compress_struct c{};
  jpeg_error_mgr err{};
  c.err = jpeg_std_error(&err);
  jpeg_create_compress(&c);
  jpeg_stdio_dest(&c, f);
  c.image_width = static_cast<JDIMENSION>(w);
  c.image_height = static_cast<JDIMENSION>(h);
  c.input_components = 3;
  c.in_color_space = JCS_RGB;
  jpeg_set_defaults(&c);
  jpeg_start_compress(&c, TRUE);
  auto rgb = pattern(w, h);
  while (c.next_scanline < c.image_height) {
    JSAMPROW row =
        rgb.data() + static_cast<std::size_t>(c.next_scanline) * static_cast<std::size_t>(w) * 3U;
    jpeg_write_scanlines(&c, &row, 1);
  }
  jpeg_finish_compress(&c);
  jpeg_destroy_compress(&c);
  std::fclose(f);
}

std::string fresh_dir(const std::string& name) {
  const std::string d = ::testing::TempDir() + name + "_" + std::to_string(getpid());
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

TEST(DdsImageFiles, PngAndJpegDecodeToRgb) {
  const std::string d = fresh_dir("images");
  write_png(d + "/b.png", 7, 5);
  write_jpeg(d + "/a.JPG", 16, 8);
  std::ofstream(d + "/notes.txt") << "not an image";
  auto files = image_files(d);
  ASSERT_TRUE(files.has_value()) << files.error().to_string();
  ASSERT_EQ(files->size(), 2U);
  EXPECT_EQ(fs::path((*files)[0]).filename(), "a.JPG");
  auto png = read_image(d + "/b.png");
  ASSERT_TRUE(png.has_value()) << png.error().to_string();
  EXPECT_EQ(png->width, 7);
  EXPECT_EQ(png->height, 5);
  EXPECT_EQ(png->rgb, pattern(7, 5)) << "PNG is lossless";
  auto jpg = read_image(d + "/a.JPG");
  ASSERT_TRUE(jpg.has_value()) << jpg.error().to_string();
  EXPECT_EQ(jpg->width, 16);
  EXPECT_EQ(jpg->height, 8);
  EXPECT_EQ(jpg->rgb.size(), 16U * 8U * 3U);
}

TEST(DdsImageFiles, BadFilesAndEmptyDirectoriesAreNamed) {
  const std::string d = fresh_dir("bad_images");
  auto none = image_files(d);
  ASSERT_FALSE(none.has_value());
  EXPECT_NE(none.error().message.find("no .png"), std::string::npos);
  std::ofstream(d + "/x.png") << "definitely not a PNG";
  auto bad = read_image(d + "/x.png");
  ASSERT_FALSE(bad.has_value());
  EXPECT_EQ(bad.error().file, d + "/x.png");
  std::ofstream(d + "/y.jpg") << "\xFF\xD8 truncated";
  EXPECT_FALSE(read_image(d + "/y.jpg").has_value());
  EXPECT_FALSE(image_files("/nonexistent/dir").has_value());
  // The CLI: bad directories exit 2.
  const std::string red = RED_CLI;
  EXPECT_EQ(WEXITSTATUS(std::system(
                (red + " camera --count 1 --from /nonexistent/dir 2>/dev/null").c_str())),
            2);
  EXPECT_EQ(
      WEXITSTATUS(std::system((red + " camera --count 1 --from '" + d + "' 2>/dev/null").c_str())),
      2);
}

TEST(DdsNodeCli, CameraFromADirectoryFeedsTheNode) {
  const std::string d = fresh_dir("camera_dir");
  write_png(d + "/0.png", 40, 30);
  write_jpeg(d + "/1.jpg", 64, 48);
  const std::string dom = " --domain " + std::to_string(test_domain());
  const std::string err = d + "/node.err";
  const std::string red = RED_CLI;
  std::thread node([&] {
    std::system((red +
                 " node '" RED_SOURCE_DIR
                 "/tests/dds/data/node.yaml' --backend synthetic --duration 3" +
                 dom + " 2> '" + err + "'")
                    .c_str());
  });
  const int cam = std::system((red + " camera --rate 10 --count 6 --encoding mono8 --from '" + d +
                               "'" + dom + " 2>/dev/null")
                                  .c_str());
  node.join();
  EXPECT_EQ(WEXITSTATUS(cam), 0);
  const std::string text = test::read_text(err);
  // Every frame that arrived was released, none rejected (best effort may lose one).
  unsigned frames = 0, released = 0;
  const auto at = text.find("red node: ");
  const auto summary = text.find(" frames (", at);
  ASSERT_NE(summary, std::string::npos) << text;
  ASSERT_EQ(std::sscanf(text.c_str() + text.rfind("red node: ", summary),
                        "red node: %u frames (%u released)", &frames, &released),
            2)
      << text;
  EXPECT_GE(frames, 4U) << text;
  EXPECT_EQ(frames, released) << text;
  EXPECT_NE(text.find("released), 0 rejected"), std::string::npos) << text;
}

}  // namespace
}  // namespace red::dds
