#include "red/dds/camera.hpp"

#include <chrono>
#include <thread>
#include <vector>

#include "red/dds/image_files.hpp"
#include "red/dds/messages.hpp"

namespace red::dds {

namespace {

// Frame k: a horizontal gradient shifted by k, and a bright square moving across.
void draw(std::vector<std::uint8_t>& data, int w, int h, int ch, bool bgr, std::uint64_t k) {
  const int side = std::max(2, std::min(w, h) / 6);
  const int sx = static_cast<int>((k * 7) % static_cast<std::uint64_t>(std::max(1, w - side)));
  const int sy = (h - side) / 2;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool square = x >= sx && x < sx + side && y >= sy && y < sy + side;
      const auto base = static_cast<std::uint8_t>((x * 160 / std::max(1, w) + k) % 160);
      std::uint8_t* p = data.data() + (static_cast<std::size_t>(y) * static_cast<std::size_t>(w) +
                                       static_cast<std::size_t>(x)) *
                                          static_cast<std::size_t>(ch);
      if (ch == 1) {
        p[0] = square ? 250 : base;
      } else {
        const std::uint8_t r = square ? 250 : base,
                           g = square ? 250 : static_cast<std::uint8_t>(base / 2),
                           b = square ? 250 : static_cast<std::uint8_t>(160 - base);
        p[0] = bgr ? b : r;
        p[1] = g;
        p[2] = bgr ? r : b;
      }
    }
}

}  // namespace

Expected<CameraReport> run_camera(const CameraOptions& o, const std::atomic<bool>& stop) {
  if (!(o.rate_hz > 0) || o.rate_hz > 10000) return Error{"", 0, "--rate must be in (0, 10000] Hz"};
  if (o.width < 1 || o.height < 1 || o.width > 16384 || o.height > 16384)
    return Error{"", 0, "--size must be WxH with 1..16384 each"};
  if (o.encoding != "rgb8" && o.encoding != "bgr8" && o.encoding != "mono8")
    return Error{"", 0, "--encoding must be rgb8, bgr8 or mono8, not '" + o.encoding + "'"};
  if (!valid_ros_topic(o.topic))
    return Error{"", 0, "--topic '" + o.topic + "' is not an absolute ROS 2 topic name"};
  if (!o.stamps_topic.empty() && !valid_ros_topic(o.stamps_topic))
    return Error{"", 0,
                 "--stamps-topic '" + o.stamps_topic + "' is not an absolute ROS 2 topic name"};
  std::vector<std::string> files;
  if (!o.from_dir.empty()) {
    auto f = image_files(o.from_dir);
    if (!f) return f.error();
    files = std::move(*f);
    if (auto first = read_image(files.front()); !first) return first.error();
  }
  auto domain =
      Domain::open(o.domain, o.config, o.shared_memory, o.security ? &*o.security : nullptr);
  if (!domain) return domain.error();
  const dds_entity_t pp = (*domain)->participant();
  const dds_entity_t topic = dds_create_topic(pp, &sensor_msgs_msg_dds__Image__desc,
                                              dds_topic_name(o.topic).c_str(), nullptr, nullptr);
  dds_qos_t* qos = make_qos(o.qos);
  const dds_entity_t writer = topic < 0 ? topic : dds_create_writer(pp, topic, qos, nullptr);
  dds_delete_qos(qos);
  if (writer < 0) return Error{"", 0, "cannot publish " + o.topic + ": " + dds_strretcode(writer)};
  dds_entity_t stamps = 0;
  if (!o.stamps_topic.empty()) {
    const dds_entity_t st =
        dds_create_topic(pp, &std_msgs_msg_dds__Header__desc,
                         dds_topic_name(o.stamps_topic).c_str(), nullptr, nullptr);
    dds_qos_t* sq = make_qos(QosSettings{}.output);
    stamps = st < 0 ? st : dds_create_writer(pp, st, sq, nullptr);
    dds_delete_qos(sq);
    if (stamps < 0)
      return Error{"", 0, "cannot publish " + o.stamps_topic + ": " + dds_strretcode(stamps)};
  }

  CameraReport report;
  const auto t0 = std::chrono::steady_clock::now();
  while (!stop.load() && std::chrono::steady_clock::now() - t0 < o.wait_for_subscriber) {
    dds_publication_matched_status_t st;
    if (dds_get_publication_matched_status(writer, &st) == DDS_RETCODE_OK && st.current_count > 0) {
      report.matched = true;
      // The reader learns of this writer a moment after the writer of the reader; best
      // effort drops what arrives in between.
      std::this_thread::sleep_for(std::chrono::milliseconds{200});
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds{20});
  }

  const int ch = o.encoding == "mono8" ? 1 : 3;
  std::vector<std::uint8_t> data(static_cast<std::size_t>(o.width) *
                                 static_cast<std::size_t>(o.height) * static_cast<std::size_t>(ch));
  const auto period = std::chrono::nanoseconds{static_cast<std::int64_t>(1e9 / o.rate_hz)};
  const auto start = std::chrono::steady_clock::now();
  auto next = start;
  for (std::uint64_t k = 0; !stop.load(); ++k) {
    if (o.count && k >= *o.count) break;
    if (o.duration && std::chrono::steady_clock::now() - start >= *o.duration) break;
    std::this_thread::sleep_until(next);
    next += period;
    if (o.skip_every > 0 && k % o.skip_every == o.skip_every - 1) {
      ++report.skipped;
      continue;
    }
    int w = o.width, h = o.height;
    if (files.empty()) {
      draw(data, w, h, ch, o.encoding == "bgr8", k);
    } else {
      auto file = read_image(files[k % files.size()]);
      if (!file) return file.error();
      w = file->width;
      h = file->height;
      data.resize(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) *
                  static_cast<std::size_t>(ch));
      for (std::size_t i = 0, n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h); i < n;
           ++i) {
        const std::uint8_t* p = file->rgb.data() + 3 * i;
        if (ch == 1) {
          data[i] = static_cast<std::uint8_t>((p[0] * 77U + p[1] * 150U + p[2] * 29U) >> 8U);
        } else {
          const bool bgr = o.encoding == "bgr8";
          data[3 * i] = bgr ? p[2] : p[0];
          data[3 * i + 1] = p[1];
          data[3 * i + 2] = bgr ? p[0] : p[2];
        }
      }
    }
    Image img{};
    stamp_now(img.header_.stamp_.sec_, img.header_.stamp_.nanosec_);
    img.header_.frame_id_ = borrow(o.frame_id);
    img.height_ = static_cast<std::uint32_t>(h);
    img.width_ = static_cast<std::uint32_t>(w);
    img.encoding_ = borrow(o.encoding);
    img.step_ = static_cast<std::uint32_t>(w * ch);
    borrow(img.data_, data);
    if (const dds_return_t rc = dds_write(writer, &img); rc < 0)
      return Error{"", 0, "publishing on " + o.topic + " failed: " + dds_strretcode(rc)};
    if (stamps > 0) dds_write(stamps, &img.header_);
    ++report.published;
  }
  return report;
}

}  // namespace red::dds
