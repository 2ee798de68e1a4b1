// The node's image conversions (docs/ROS2.md): nearest-neighbour resize to the model's input, as
// luminance and as RGB, for every accepted encoding, padded rows, down- and upscaling.

#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "red/dds/image.hpp"

namespace red::dds {
namespace {

struct TestImage {
  std::string encoding;
  std::vector<std::uint8_t> data;
  Image img{};
  TestImage(std::string enc, std::uint32_t w, std::uint32_t h, std::uint32_t step)
      : encoding(std::move(enc)), data(static_cast<std::size_t>(h) * step) {
    for (std::size_t i = 0; i < data.size(); ++i) data[i] = static_cast<std::uint8_t>(i * 29 + 7);
    img.encoding_ = borrow(encoding);
    img.width_ = w;
    img.height_ = h;
    img.step_ = step;
    borrow(img.data_, data);
  }
};

// The source pixel of output (x, y) by the definition: row y·H/h, column x·W/w.
const std::uint8_t* source(const Image& img, int x, int y, int w, int h, int ch) {
  const std::uint64_t sy = static_cast<std::uint64_t>(y) * img.height_ / static_cast<unsigned>(h);
  const std::uint64_t sx = static_cast<std::uint64_t>(x) * img.width_ / static_cast<unsigned>(w);
  return img.data_._buffer + sy * img.step_ + sx * static_cast<unsigned>(ch);
}

TEST(DdsImage, ConversionsPickTheNearestSourcePixelForEveryEncodingAndSize) {
  struct Case {
    std::string encoding;
    int ch;
    std::uint32_t w, h, step;
  };
  for (const Case& c : {Case{"rgb8", 3, 7, 5, 21}, Case{"bgr8", 3, 7, 5, 24},
                        Case{"mono8", 1, 9, 4, 12}, Case{"rgb8", 3, 2, 3, 6}}) {
    TestImage t(c.encoding, c.w, c.h, c.step);
    ASSERT_FALSE(check_image(t.img).has_value()) << c.encoding;
    for (const auto& [w, h] : {std::pair{3, 2}, std::pair{7, 5}, std::pair{16, 9}}) {
      SCOPED_TRACE(c.encoding + " " + std::to_string(w) + "x" + std::to_string(h));
      GrayFrame gray;
      std::vector<std::uint8_t> rgb;
      to_gray(t.img, w, h, gray);
      to_rgb(t.img, w, h, rgb);
      ASSERT_EQ(gray.pixels.size(), static_cast<std::size_t>(w * h));
      ASSERT_EQ(rgb.size(), static_cast<std::size_t>(w * h * 3));
      EXPECT_EQ(gray.width, w);
      EXPECT_EQ(gray.height, h);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          const std::uint8_t* p = source(t.img, x, y, w, h, c.ch);
          std::uint32_t r = p[0], g = p[0], b = p[0];
          if (c.ch == 3) {
            r = c.encoding == "bgr8" ? p[2] : p[0];
            g = p[1];
            b = c.encoding == "bgr8" ? p[0] : p[2];
          }
          const auto i = static_cast<std::size_t>(y * w + x);
          EXPECT_EQ(rgb[3 * i], r);
          EXPECT_EQ(rgb[3 * i + 1], g);
          EXPECT_EQ(rgb[3 * i + 2], b);
          const std::uint32_t luma = c.ch == 1 ? r : (r * 77U + g * 150U + b * 29U) >> 8U;
          EXPECT_EQ(gray.pixels[i], luma);
        }
    }
  }
}

}  // namespace
}  // namespace red::dds

namespace red::dds {
namespace {

constexpr std::int64_t kMs = 1'000'000;

// Frames missing from a stream are inferred from its stamps at its own period, once four
// gaps are known; out-of-order stamps are no gaps.
TEST(DdsStampGaps, CountsTheFramesThatFitInAGap) {
  StampGaps g;
  std::int64_t t = 5'000 * kMs;
  std::uint64_t missing = 0;
  for (int i = 0; i < 5; ++i, t += 50 * kMs) missing += g.add(t);
  EXPECT_EQ(missing, 0U);
  t += 100 * kMs;  // two frames (at +0 and +50 ms) not received
  EXPECT_EQ(g.add(t), 2U);
  t += 50 * kMs;
  EXPECT_EQ(g.add(t), 0U);
  t += 70 * kMs;  // jitter below 1.5 periods: nothing missing
  EXPECT_EQ(g.add(t), 0U);
  EXPECT_EQ(g.add(t - 20 * kMs), 0U);  // out of order
  EXPECT_EQ(g.add(t), 0U);             // repeated
  t += 100 * kMs;
  EXPECT_EQ(g.add(t), 1U);
}

TEST(DdsStampGaps, NothingIsInferredBeforeFourGapsAreKnown) {
  StampGaps g;
  EXPECT_EQ(g.add(0), 0U);
  EXPECT_EQ(g.add(50 * kMs), 0U);
  EXPECT_EQ(g.add(500 * kMs), 0U);  // too early to know the period
}

}  // namespace
}  // namespace red::dds
