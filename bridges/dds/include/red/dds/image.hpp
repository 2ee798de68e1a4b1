#pragma once
/// \file
/// Checking a received sensor_msgs/Image and bringing it to the model's input size (§14).

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "red/dds/messages.hpp"

namespace red::dds {

/// Why a received image was rejected; counted and reported in the diagnostics. The last two
/// are about a writer on an input topic rather than a message: DDS never delivers a sample
/// of another type (WrongType: the writer's type name differs) or from a writer whose QoS
/// the reader cannot accept (IncompatibleQos), so each such writer is counted once.
enum class Reject : std::uint8_t {
  UnknownEncoding,
  AbsurdSize,
  BadStep,
  DataSize,
  WrongType,
  IncompatibleQos
};
inline constexpr int kRejectKinds = 6;

/// Short name of a reason, as it appears in logs and diagnostics ("unknown_encoding", ...).
const char* to_string(Reject r) noexcept;

/// The largest width or height accepted; larger ones are "absurd" (a corrupt header).
inline constexpr std::uint32_t kMaxImageSide = 16384;

/// Checks an image's encoding (rgb8, bgr8, mono8), sizes, step and data size
/// (data = height · step); nothing when it can be used.
std::optional<Reject> check_image(const Image& img) noexcept;

/// A single-channel frame at the model's input size (row-major, height × width).
struct GrayFrame {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> pixels;
};

/// Converts a checked image to luminance, resized (nearest neighbour) to width × height.
void to_gray(const Image& img, int width, int height, GrayFrame& out);

/// Converts a checked image to interleaved RGB (mono8 replicated), resized (nearest
/// neighbour) to width × height: the model input a backend gets.
void to_rgb(const Image& img, int width, int height, std::vector<std::uint8_t>& out);

}  // namespace red::dds
