#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <limits>
#include <thread>

#include "node_impl.hpp"

namespace red::dds {

FrameStats frame_stats(const FrameView& g) {
  FrameStats f;
  const std::size_t w = static_cast<std::size_t>(g.width), h = static_cast<std::size_t>(g.height);
  std::uint64_t left = 0, right = 0;
  for (std::size_t y = 0; y < h; ++y) {
    const std::uint8_t* row = g.data + y * w;
    std::uint32_t l = 0, r = 0;
    for (std::size_t x = 0; x < w / 2; ++x) l += row[x];
    for (std::size_t x = w / 2; x < w; ++x) r += row[x];
    left += l;
    right += r;
  }
  f.left = static_cast<double>(left);
  f.right = static_cast<double>(right);
  f.mean = (f.left + f.right) / std::max(1.0, static_cast<double>(w * h));
  // An integer pixel is above the threshold exactly when it is above its floor.
  const auto above =
      static_cast<std::uint8_t>(std::min(255.0, std::floor(f.mean + (255.0 - f.mean) / 2.0)));
  f.x0 = g.width;
  f.y0 = g.height;
  for (std::size_t y = 0; y < h; ++y) {
    const std::uint8_t* row = g.data + y * w;
    std::uint32_t n = 0;
    for (std::size_t x = 0; x < w; ++x) n += row[x] > above ? 1U : 0U;
    if (n == 0) continue;
    std::size_t first = 0, last = w - 1;
    while (row[first] <= above) ++first;
    while (row[last] <= above) --last;
    f.x0 = std::min(f.x0, static_cast<int>(first));
    f.x1 = std::max(f.x1, static_cast<int>(last));
    f.y0 = std::min(f.y0, static_cast<int>(y));
    f.y1 = static_cast<int>(y);
    f.bright += static_cast<int>(n);
  }
  return f;
}

void Node::Impl::reject(std::size_t sensor, Reject why, const Image& img) {
  std::uint64_t n = 0;
  {
    std::lock_guard lock(counters_mu);
    n = ++counters.rejected[static_cast<std::size_t>(why)];
  }
  if (n <= 3 || n % 100 == 0)
    std::cerr << "red node: rejected an image on " << topics.sensors[sensor] << " ("
              << to_string(why) << ": encoding '" << (img.encoding_ ? img.encoding_ : "") << "', "
              << img.width_ << "x" << img.height_ << ", step " << img.step_ << ", "
              << img.data_._length << " data bytes; " << n << " so far)\n";
}

// A writer on the sensor's topic that DDS did not match: a type name other than
// sensor_msgs::msg::dds_::Image_ (Cyclone reports it as the type-consistency policy) or a
// QoS the reader cannot accept. Its samples never arrive, so the writer counts once.
// Called by Cyclone DDS on its own thread, once per writer.
void Node::Impl::on_unmatched_writer(dds_entity_t, const dds_requested_incompatible_qos_status_t st,
                                     void* arg) {
  const ReaderCtx& ctx = *static_cast<const ReaderCtx*>(arg);
  if (ctx.impl == nullptr || st.total_count_change == 0) return;
  Impl& m = *ctx.impl;
  const bool type = st.last_policy_id == DDS_TYPE_CONSISTENCY_ENFORCEMENT_QOS_POLICY_ID;
  const Reject why = type ? Reject::WrongType : Reject::IncompatibleQos;
  std::uint64_t n = 0;
  {
    std::lock_guard lock(m.counters_mu);
    n = m.counters.rejected[static_cast<std::size_t>(why)] += st.total_count_change;
  }
  std::cerr << "red node: a writer on " << m.topics.sensors[ctx.sensor] << " was not matched ("
            << (type ? "wrong_type: its type is not sensor_msgs/msg/Image"
                     : "incompatible_qos: DDS QoS policy id " +
                           std::to_string(static_cast<int>(st.last_policy_id)))
            << "; " << n << " so far): its messages are not received\n";
}

// Samples DDS could not deliver (every frame offered is released or counted). Called by
// Cyclone DDS on its own thread.
void Node::Impl::count_undelivered(std::size_t sensor, Reject why, std::int64_t change) {
  if (change <= 0) return;
  std::uint64_t n = 0;
  {
    std::lock_guard lock(counters_mu);
    n = counters.rejected[static_cast<std::size_t>(why)] += static_cast<std::uint64_t>(change);
  }
  // The first few, then every hundredth: a lossy link must not flood the log.
  if (n <= 3 || n % 100 < static_cast<std::uint64_t>(change))
    std::cerr << "red node: " << change << " frame(s) on " << topics.sensors[sensor]
              << (why == Reject::LostInTransport
                      ? " lost in transport (large frames need a larger socket receive buffer "
                        "or shared memory: docs/ROS2.md \"Large frames\")"
                      : " rejected by DDS (the reader's resource limits)")
              << "; " << n << " so far\n";
}

void Node::Impl::on_sample_lost(dds_entity_t, const dds_sample_lost_status_t st, void* arg) {
  const ReaderCtx& ctx = *static_cast<const ReaderCtx*>(arg);
  if (ctx.impl != nullptr)
    ctx.impl->count_undelivered(ctx.sensor, Reject::LostInTransport, st.total_count_change);
}

void Node::Impl::on_sample_rejected(dds_entity_t, const dds_sample_rejected_status_t st,
                                    void* arg) {
  const ReaderCtx& ctx = *static_cast<const ReaderCtx*>(arg);
  if (ctx.impl != nullptr)
    ctx.impl->count_undelivered(ctx.sensor, Reject::RejectedByDds, st.total_count_change);
}

// A checked frame is a release (docs/ROS2.md): the pixels are moved out of the sample, not
// converted; the backend gets them as a LazyFrame that converts them to the model's input
// when a unit first needs them (the encoder's start), so a frame whose job is dropped
// before it runs is never converted. Only after the release is the frame's luminance (what
// the outputs are computed from) converted, here, off the release path.
void Node::Impl::accept(std::size_t sensor, Image& img, TimePoint taken, WallStamp taken_wall) {
  const auto& in = scenario.model.input;
  const int h = in.size() >= 3 ? static_cast<int>(in[1]) : 192;
  const int w = in.size() >= 3 ? static_cast<int>(in[2]) : 384;
  const int channels = !in.empty() && in[0] == 1 ? 1 : 3;
  std::shared_ptr<const ReceivedImage> received = ReceivedImage::take(img);
  const HeaderValue& header = received->header();
  auto gray = std::make_shared<const ConvertedImage>(received, w, h, 1);
  std::shared_ptr<const LazyFrame> input =
      channels == 1 ? gray : std::make_shared<const ConvertedImage>(received, w, h, 3);
  std::uint64_t id = 0;
  std::uint64_t missing = 0;
  {
    std::lock_guard lock(frames_mu);
    SensorState& st = sensors[sensor];
    id = st.next_id++;
    FrameSlot& slot = st.ring[id % kFrameRing];
    slot.id = id;
    slot.header = header;
    slot.gray = gray;
    slot.stats.reset();
    st.last = taken;
    ++st.frames;
    missing = st.gaps.add(static_cast<std::int64_t>(header.sec) * 1'000'000'000 +
                          static_cast<std::int64_t>(header.nanosec));
  }
  count_undelivered(sensor, Reject::LostInTransport, static_cast<std::int64_t>(missing));
  received.reset();  // the two conversions hold it until both are done
  const FrameView px{w, h, channels, nullptr, std::move(input)};
  released_at.reset();
  const TimePoint pushed = clock.now();
  pushing_node = this;
  const bool released = runtime->push_frame(static_cast<int>(sensor), id, &px);
  pushing_node = nullptr;
  const TimePoint returned = clock.now();
  const double us = to_us(pushed - taken);
  if (!released) {
    std::lock_guard lock(frames_mu);
    if (FrameSlot& slot = sensors[sensor].ring[id % kFrameRing]; slot.id == id)
      slot.gray.reset();  // no job reads it: let the received pixels go now
  }
  {
    std::lock_guard lock(counters_mu);
    ++counters.frames;
    if (released) {
      ++counters.released;
      if (released_intake_us.size() < kIntakeWindow) {
        released_intake_us.push_back(us);
        taken_released_us.push_back(released_at ? to_us(*released_at - taken)
                                                : std::numeric_limits<double>::quiet_NaN());
      }
      if (released_at) {
        record(timings.after_release_us, after_releases++, to_us(returned - *released_at));
      }
    }
    // Wall clocks: the sender's stamp against this machine's time of the take.
    const double transport = (static_cast<double>(taken_wall.sec - img.header_.stamp_.sec_) * 1e9 +
                              (static_cast<double>(taken_wall.nanosec) -
                               static_cast<double>(img.header_.stamp_.nanosec_))) /
                             1e3;
    record(timings.intake_us, intakes, us);
    record(timings.transport_us, intakes, transport);
    ++intakes;
  }
  // After the release: the outputs' luminance and what they are computed from, so that the
  // publisher finds them ready when the job ends.
  if (released) {
    const FrameStats fs = frame_stats(gray->pixels());
    std::lock_guard lock(frames_mu);
    if (FrameSlot& slot = sensors[sensor].ring[id % kFrameRing]; slot.id == id) slot.stats = fs;
  }
}

void Node::Impl::receive_main() {
  std::vector<void*> samples(8, nullptr);
  std::vector<dds_sample_info_t> infos(8);
  // Frames that arrive before the runtime accepts them wait in the readers' history.
  while (receiving.load(std::memory_order_acquire) && !runtime->accepting_frames())
    std::this_thread::sleep_for(std::chrono::milliseconds{1});
  while (receiving.load(std::memory_order_acquire)) {
    dds_waitset_wait(waitset, nullptr, 0, DDS_MSECS(100));
    for (std::size_t s = 0; s < readers.size(); ++s) {
      for (;;) {
        std::fill(samples.begin(), samples.end(), nullptr);
        const dds_return_t n = dds_take(readers[s], samples.data(), infos.data(), samples.size(),
                                        static_cast<uint32_t>(samples.size()));
        if (n <= 0) break;
        const TimePoint taken = clock.now();
        WallStamp taken_wall;
        stamp_now(taken_wall.sec, taken_wall.nanosec);
        for (dds_return_t i = 0; i < n; ++i) {
          if (!infos[static_cast<std::size_t>(i)].valid_data) continue;
          Image& img = *static_cast<Image*>(samples[static_cast<std::size_t>(i)]);
          if (auto why = check_image(img))
            reject(s, *why, img);
          else
            accept(s, img, taken, taken_wall);
        }
        dds_return_loan(readers[s], samples.data(), n);
      }
    }
  }
}

}  // namespace red::dds
