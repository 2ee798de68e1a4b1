#pragma once
/// \file
/// Checking a received sensor_msgs/Image and bringing it to the model's input size (docs/ROS2.md).

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "red/dds/messages.hpp"
#include "red/runtime/backend.hpp"

namespace red::dds {

/// Why an image was not taken; counted and reported in the diagnostics and the summary.
/// The first four are about a message. WrongType and IncompatibleQos are about a writer on
/// an input topic: DDS never delivers a sample of another type (the writer's type name
/// differs) or from a writer whose QoS the reader cannot accept, so each such writer is
/// counted once. The last two are samples DDS itself could not deliver: LostInTransport
/// (DDS's SAMPLE_LOST status: a sample announced but never complete, typically a large
/// frame whose fragments a full socket receive buffer dropped, docs/ROS2.md "Large
/// frames") and RejectedByDds (SAMPLE_REJECTED: the reader's resource limits).
enum class Reject : std::uint8_t {
  UnknownEncoding,
  AbsurdSize,
  BadStep,
  DataSize,
  WrongType,
  IncompatibleQos,
  LostInTransport,
  RejectedByDds
};
inline constexpr int kRejectKinds = 8;

/// Short name of a reason, as it appears in logs and diagnostics ("unknown_encoding", ...).
const char* to_string(Reject r) noexcept;

/// Frames missing from one sensor's stream, inferred from the header stamps: a gap of more
/// than 1.5 of the stream's own period (the median of its last 16 gaps, once 4 are known)
/// counts the frames that fit in it as missing. DDS cannot say this for a best-effort
/// reader: a large frame whose fragments were dropped is never announced as lost. A
/// publisher that slows down counts as missing frames until the median follows it (8
/// frames); stamps out of order are ignored.
class StampGaps {
 public:
  /// The frames missing before this one (0 if none or not known yet).
  std::uint64_t add(std::int64_t stamp_ns);

 private:
  static constexpr std::size_t kWindow = 16;
  std::int64_t last_ = 0;
  bool started_ = false;
  std::array<std::int64_t, kWindow> gaps_{};
  std::size_t count_ = 0;  // gaps seen, the last kWindow of them kept
};

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

/// A checked image as received, kept whole: its pixel buffer moved out of the DDS sample
/// (not copied), its header and layout copied. Immutable once made; shared by the
/// conversions that still need it (ConvertedImage), freed when the last of them is done.
class ReceivedImage {
 public:
  /// Takes `img`'s pixels: a buffer Cyclone allocated for the sample (`_release` set) is moved
  /// and the sample's data sequence left empty (dds_return_loan then frees nothing of it);
  /// a borrowed one is copied. `img` must pass check_image().
  static std::shared_ptr<const ReceivedImage> take(Image& img);
  ~ReceivedImage();
  ReceivedImage(const ReceivedImage&) = delete;
  ReceivedImage& operator=(const ReceivedImage&) = delete;

  /// The header (stamp, frame_id) as received.
  [[nodiscard]] const HeaderValue& header() const noexcept { return header_; }
  /// A borrowed message over the kept pixels (for to_gray / to_rgb); valid while this lives.
  [[nodiscard]] Image view() const noexcept;
  /// Whether the pixel buffer was moved out of the sample rather than copied.
  [[nodiscard]] bool moved() const noexcept { return moved_; }

 private:
  ReceivedImage() = default;
  HeaderValue header_;
  std::string encoding_;
  std::uint32_t width_ = 0, height_ = 0, step_ = 0, size_ = 0;
  std::uint8_t* data_ = nullptr;  // dds_alloc'ed: freed with dds_free
  bool moved_ = false;
};

/// A received image converted, when first asked for, to the model's input size (docs/ROS2.md:
/// released first, converted later): RGB (channels 3) or luminance (channels 1), nearest
/// neighbour. The received image is let go once converted. Thread-safe (LazyFrame).
class ConvertedImage final : public LazyFrame {
 public:
  /// The conversion of `source` to width × height × channels (1 or 3).
  ConvertedImage(std::shared_ptr<const ReceivedImage> source, int width, int height, int channels);

 protected:
  void convert(std::uint8_t* out) const override;

 private:
  mutable std::shared_ptr<const ReceivedImage> source_;  // reset by the one convert()
};

}  // namespace red::dds
