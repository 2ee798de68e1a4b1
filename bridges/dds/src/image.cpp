#include "red/dds/image.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <utility>
#include <vector>

namespace red::dds {

const char* to_string(Reject r) noexcept {
  switch (r) {
    case Reject::UnknownEncoding:
      return "unknown_encoding";
    case Reject::AbsurdSize:
      return "absurd_size";
    case Reject::BadStep:
      return "bad_step";
    case Reject::DataSize:
      return "data_size";
    case Reject::WrongType:
      return "wrong_type";
    case Reject::IncompatibleQos:
      return "incompatible_qos";
    case Reject::LostInTransport:
      return "lost_in_transport";
    case Reject::RejectedByDds:
      return "rejected_by_dds";
  }
  return "?";
}

std::uint64_t StampGaps::add(std::int64_t stamp_ns) {
  if (!started_) {
    started_ = true;
    last_ = stamp_ns;
    return 0;
  }
  const std::int64_t gap = stamp_ns - last_;
  if (gap <= 0) return 0;  // out of order or repeated: not a gap
  last_ = stamp_ns;
  std::uint64_t missing = 0;
  const std::size_t known = std::min(count_, kWindow);
  if (known >= 4) {
    std::array<std::int64_t, kWindow> sorted{};
    std::copy_n(gaps_.begin(), known, sorted.begin());
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(known / 2),
                     sorted.begin() + static_cast<std::ptrdiff_t>(known));
    const auto period = static_cast<double>(sorted[known / 2]);
    if (period > 0 && static_cast<double>(gap) > 1.5 * period)
      missing = static_cast<std::uint64_t>(std::llround(static_cast<double>(gap) / period)) - 1;
  }
  gaps_[count_++ % kWindow] = gap;
  return missing;
}

namespace {

int channels(const char* encoding) noexcept {
  if (encoding == nullptr) return 0;
  if (std::strcmp(encoding, "rgb8") == 0 || std::strcmp(encoding, "bgr8") == 0) return 3;
  if (std::strcmp(encoding, "mono8") == 0) return 1;
  return 0;
}

}  // namespace

std::optional<Reject> check_image(const Image& img) noexcept {
  const int ch = channels(img.encoding_);
  if (ch == 0) return Reject::UnknownEncoding;
  if (img.width_ == 0 || img.height_ == 0 || img.width_ > kMaxImageSide ||
      img.height_ > kMaxImageSide)
    return Reject::AbsurdSize;
  const std::uint64_t row = static_cast<std::uint64_t>(img.width_) * static_cast<std::uint64_t>(ch);
  if (img.step_ < row) return Reject::BadStep;
  if (static_cast<std::uint64_t>(img.data_._length) !=
      static_cast<std::uint64_t>(img.height_) * img.step_)
    return Reject::DataSize;
  return std::nullopt;
}

namespace {

// The source byte offset of each output column (nearest neighbour), computed once per
// call rather than a 64-bit division per pixel (the node does this for every frame before
// its release). The vector is the calling thread's own and is reused between calls.
const std::vector<std::uint64_t>& column_offsets(const Image& img, int width, int ch) {
  thread_local std::vector<std::uint64_t> xs;
  xs.resize(static_cast<std::size_t>(width));
  for (int x = 0; x < width; ++x)
    xs[static_cast<std::size_t>(x)] = static_cast<std::uint64_t>(x) * img.width_ /
                                      static_cast<std::uint64_t>(width) *
                                      static_cast<std::uint64_t>(ch);
  return xs;
}

const std::uint8_t* source_row(const Image& img, int y, int height) {
  const std::uint64_t sy =
      static_cast<std::uint64_t>(y) * img.height_ / static_cast<std::uint64_t>(height);
  return img.data_._buffer + sy * img.step_;
}

}  // namespace

namespace {

// Luminance of a checked image, resized to width × height, into out[width · height].
void gray_into(const Image& img, int width, int height, std::uint8_t* o) {
  const int ch = channels(img.encoding_);
  const bool bgr = std::strcmp(img.encoding_, "bgr8") == 0;
  const std::vector<std::uint64_t>& xs = column_offsets(img, width, ch);
  for (int y = 0; y < height; ++y) {
    const std::uint8_t* row = source_row(img, y, height);
    if (ch == 1) {
      for (std::uint64_t sx : xs) *o++ = row[sx];
      continue;
    }
    for (std::uint64_t sx : xs) {
      const std::uint8_t* p = row + sx;
      const std::uint32_t r = bgr ? p[2] : p[0], b = bgr ? p[0] : p[2];
      *o++ = static_cast<std::uint8_t>((r * 77U + p[1] * 150U + b * 29U) >> 8U);  // BT.601 luma
    }
  }
}

// Interleaved RGB of a checked image, resized to width × height, into out[width · height · 3].
void rgb_into(const Image& img, int width, int height, std::uint8_t* o) {
  const int ch = channels(img.encoding_);
  const bool bgr = std::strcmp(img.encoding_, "bgr8") == 0;
  const std::vector<std::uint64_t>& xs = column_offsets(img, width, ch);
  for (int y = 0; y < height; ++y) {
    const std::uint8_t* row = source_row(img, y, height);
    for (std::uint64_t sx : xs) {
      const std::uint8_t* p = row + sx;
      if (ch == 1) {
        o[0] = o[1] = o[2] = p[0];
      } else {
        o[0] = bgr ? p[2] : p[0];
        o[1] = p[1];
        o[2] = bgr ? p[0] : p[2];
      }
      o += 3;
    }
  }
}

}  // namespace

void to_gray(const Image& img, int width, int height, GrayFrame& out) {
  out.width = width;
  out.height = height;
  out.pixels.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  gray_into(img, width, height, out.pixels.data());
}

void to_rgb(const Image& img, int width, int height, std::vector<std::uint8_t>& out) {
  out.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 3U);
  rgb_into(img, width, height, out.data());
}

std::shared_ptr<const ReceivedImage> ReceivedImage::take(Image& img) {
  std::shared_ptr<ReceivedImage> r(new ReceivedImage);
  r->header_ = HeaderValue::from(img.header_);
  r->encoding_ = img.encoding_ != nullptr ? img.encoding_ : "";
  r->width_ = img.width_;
  r->height_ = img.height_;
  r->step_ = img.step_;
  r->size_ = img.data_._length;
  if (img.data_._release && img.data_._buffer != nullptr) {
    // The sample's own buffer (Cyclone allocated it with dds_alloc): ours from now on.
    r->data_ = img.data_._buffer;
    r->moved_ = true;
    img.data_._buffer = nullptr;
    img.data_._length = img.data_._maximum = 0;
    img.data_._release = false;
  } else {
    r->data_ = static_cast<std::uint8_t*>(dds_alloc(std::max<std::uint32_t>(1, r->size_)));
    if (r->size_ > 0) std::memcpy(r->data_, img.data_._buffer, r->size_);
  }
  return r;
}

ReceivedImage::~ReceivedImage() {
  dds_free(data_);
}

Image ReceivedImage::view() const noexcept {
  Image v{};
  header_.fill(v.header_);
  v.encoding_ = const_cast<char*>(encoding_.c_str());  // never written through
  v.width_ = width_;
  v.height_ = height_;
  v.step_ = step_;
  v.data_._buffer = data_;
  v.data_._length = v.data_._maximum = size_;
  v.data_._release = false;
  return v;
}

ConvertedImage::ConvertedImage(std::shared_ptr<const ReceivedImage> source, int width, int height,
                               int channels)
    : LazyFrame(width, height, channels), source_(std::move(source)) {}

void ConvertedImage::convert(std::uint8_t* out) const {
  const Image img = source_->view();
  if (channels() == 1)
    gray_into(img, width(), height(), out);
  else
    rgb_into(img, width(), height(), out);
  // Converted: this frame no longer needs the received pixels (the last holder frees them).
  source_.reset();
}

}  // namespace red::dds
