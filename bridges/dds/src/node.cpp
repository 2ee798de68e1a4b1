#include "red/dds/node.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <iostream>
#include <limits>
#include <mutex>
#include <thread>

#include <pthread.h>
#include <sched.h>

#include "red/core/clock.hpp"
#include "red/metrics/metrics.hpp"
#include "red/sched/policy.hpp"
#include "red/sim/run.hpp"

namespace red::dds {

OutputKind output_kind(const std::string& head) noexcept {
  if (head == "steer") return OutputKind::Velocity;
  if (head == "det") return OutputKind::Detections;
  return OutputKind::Mask;
}

NodeTopics node_topics(const Scenario& s, const Remaps& remaps) {
  NodeTopics t;
  for (const SensorSpec& sensor : s.sensors)
    t.sensors.push_back(
        remaps.apply(sensor.topic.empty() ? "/" + sensor.name + "/image_raw" : sensor.topic));
  const auto add = [&](int op, const OperationSpec& spec) {
    for (const NodeSpec& n : spec.nodes) {
      const auto key = std::make_pair(op, n.name);
      t.nodes[key] =
          remaps.apply(n.topic.empty() ? "/red/" + s.operation_name(op) + "/" + n.name : n.topic);
      t.heads[key] = n.head;
    }
  };
  for (int i = 0; i < s.operation_count(); ++i)
    if (s.initial[static_cast<std::size_t>(i)]) add(i, *s.initial[static_cast<std::size_t>(i)]);
  for (const EventSpec& e : s.events)
    for (const auto& [op, spec] : e.changes)
      if (spec) add(op, *spec);
  t.diagnostics = remaps.apply("/diagnostics");
  return t;
}

namespace {

constexpr std::size_t kFrameRing = 32;        // frames kept per sensor for outputs
constexpr std::size_t kLatencyWindow = 1024;  // latencies kept per operation
constexpr std::size_t kDecisionWindow = 4096;
constexpr std::size_t kIntakeWindow = 16384;  // frame intake times kept (newest)

// What a frame's outputs are computed from (fixed rules, docs/DESIGN.md, "Built-in model": the
// built-in model's weights are random), once per frame however many heads publish it, on the
// receiving thread after the release (off the way from a job's end to its outputs).
struct FrameStats {
  double mean = 0;
  double left = 0, right = 0;            // luminance sums of the left and right halves
  int x0 = 0, y0 = 0, x1 = -1, y1 = -1;  // box around the pixels brighter than the threshold
  int bright = 0;                        // how many: above mean + (255 - mean) / 2
};

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

struct FrameSlot {
  std::uint64_t id = ~std::uint64_t{0};
  HeaderValue header;
  // The frame's luminance at the model's input size that the outputs are computed from,
  // converted after the release (or by the publisher, whichever asks first; LazyFrame).
  std::shared_ptr<const ConvertedImage> gray;
  std::optional<FrameStats> stats;  // computed after the release, with the luminance
};

struct SensorState {
  std::vector<FrameSlot> ring{kFrameRing};
  std::uint64_t next_id = 0;
  std::uint64_t frames = 0;
  std::optional<TimePoint> last;  // steady time of the last accepted frame
  StampGaps gaps;                 // frames missing from its stream (the receiving thread's)
};

struct OpStats {
  std::uint64_t jobs = 0, completed = 0, missed = 0, dropped = 0;
  double qoe_sum = 0;
  std::vector<double> latency_ms;  // ring of the last kLatencyWindow
  std::size_t next = 0;
};

// A wall-clock time as ROS 2 stamps carry it.
struct WallStamp {
  std::int32_t sec = 0;
  std::uint32_t nanosec = 0;
};

// One output to publish: a node of a finished job and the frame its head read.
struct Output {
  int operation = -1;
  std::string node;
  int head = -1;
  int sensor = -1;
  std::uint64_t frame = 0;
  TimePoint ended{0};  // when its job ended
};

// The node whose receiving thread is inside Runtime::push_frame() on this thread: the
// runtime releases a pushed frame's job on the pushing thread when its lock is free (a
// direct release), and the node's observer stamps that moment (taken -> released, docs/ROS2.md).
thread_local const void* pushing_node = nullptr;

std::string fmt_double(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

}  // namespace

struct Node::Impl final : Observer {
  Scenario scenario;
  const Profile& profile;
  Backend& backend;
  NodeOptions options;
  NodeTopics topics;
  SteadyClock clock;

  std::unique_ptr<Domain> domain;
  std::vector<dds_entity_t> readers;  // per sensor
  struct ReaderCtx {
    Impl* impl = nullptr;
    std::size_t sensor = 0;
  };
  std::atomic<bool> warned_matched_but_silent{false};
  std::vector<int> matched_silent_ticks;        // per sensor (the diagnostics thread's)
  std::vector<ReaderCtx> reader_ctx;            // per sensor, the argument of its reader's listener
  std::map<std::string, dds_entity_t> writers;  // by output topic
  dds_entity_t diag_writer = 0;
  dds_entity_t waitset = 0;
  dds_entity_t wake = 0;  // guard condition: stop receiving
  std::unique_ptr<Runtime> runtime;

  // The receiving thread takes frames_mu before each release (the frame ring): nothing else
  // holds it for more than a copy. Counters and timings have their own lock.
  mutable std::mutex frames_mu;  // sensors
  std::vector<SensorState> sensors;
  mutable std::mutex counters_mu;  // counters, timings and the vectors below
  NodeCounters counters;
  Node::Timings timings;  // rings of the newest kIntakeWindow each
  std::uint64_t intakes = 0, publishes = 0, after_releases = 0, publish_wakes = 0;

  // Observer state: touched only from observer callbacks (serialized by the runtime).
  std::map<JobId, std::vector<Output>> finished_heads;

  std::mutex stats_mu;
  std::vector<OpStats> stats;
  std::vector<double> decisions_us;
  std::uint64_t decisions_seen = 0;  // cursor into the runtime's decision times
  std::uint64_t decision_slot = 0;   // next slot of decisions_us to overwrite once full

  std::mutex pub_mu;
  std::condition_variable pub_cv;
  std::deque<Output> queue;
  bool publishing = true;
  std::atomic<bool> receiving{true};
  // Per released frame, in release order: taken from the reader -> push_frame() called
  // (paired with RuntimeReport::frame_release_us), and taken -> released when the runtime
  // released it on the receiving thread (NaN when it was posted to the synchronizer).
  std::vector<double> released_intake_us, taken_released_us;
  // Receiving thread only: when the job of the frame being pushed was released, if it was
  // released on this thread (set by on_job_release() during push_frame()).
  std::optional<TimePoint> released_at;
  std::vector<std::uint8_t> mask;  // the publisher's output buffer, reused

  Impl(const Scenario& s, const Profile& p, Backend& b, NodeOptions o)
      : scenario(s), profile(p), backend(b), options(std::move(o)) {
    // Frame arrivals are the releases (docs/ROS2.md): run until stop() or the given duration.
    scenario.duration = options.duration.value_or(std::chrono::hours{24 * 365});
    topics = node_topics(scenario, options.remaps);
    sensors.resize(scenario.sensors.size());
    stats.resize(static_cast<std::size_t>(scenario.operation_count()));
  }

  ~Impl() override {
    if (domain) {
      for (dds_entity_t r : readers) dds_delete(r);
      for (auto& [t, w] : writers) dds_delete(w);
      if (diag_writer > 0) dds_delete(diag_writer);
      if (waitset > 0) dds_delete(waitset);
      if (wake > 0) dds_delete(wake);
    }
  }

  Expected<bool> open() {
    auto d = Domain::open(options.domain, options.config, options.shared_memory);
    if (!d) return d.error();
    domain = std::move(*d);
    const dds_entity_t pp = domain->participant();
    const auto fail = [](const std::string& what, dds_return_t rc) {
      return Error{"", 0, what + ": " + dds_strretcode(rc)};
    };
    dds_qos_t* in_qos = make_qos(options.qos.input);
    dds_qos_t* out_qos = make_qos(options.qos.output);
    waitset = dds_create_waitset(pp);
    wake = dds_create_guardcondition(pp);
    dds_waitset_attach(waitset, wake, -1);
    Expected<bool> result = true;
    // A writer DDS refuses to match (another type, an incompatible QoS) is reported to a
    // listener, one call per writer (a waitset would see only the last of several).
    reader_ctx.resize(topics.sensors.size());
    for (std::size_t i = 0; i < topics.sensors.size() && result; ++i) {
      const dds_entity_t topic =
          dds_create_topic(pp, &sensor_msgs_msg_dds__Image__desc,
                           dds_topic_name(topics.sensors[i]).c_str(), nullptr, nullptr);
      reader_ctx[i] = {this, i};
      dds_listener_t* l = dds_create_listener(nullptr);
      dds_lset_requested_incompatible_qos_arg(l, &Impl::on_unmatched_writer, &reader_ctx[i], true);
      dds_lset_sample_lost_arg(l, &Impl::on_sample_lost, &reader_ctx[i], true);
      dds_lset_sample_rejected_arg(l, &Impl::on_sample_rejected, &reader_ctx[i], true);
      const dds_entity_t r = topic < 0 ? topic : dds_create_reader(pp, topic, in_qos, l);
      dds_delete_listener(l);
      if (r < 0) {
        result = fail("cannot subscribe to " + topics.sensors[i], r);
        break;
      }
      dds_set_status_mask(r, DDS_DATA_AVAILABLE_STATUS);
      dds_waitset_attach(waitset, r, static_cast<dds_attach_t>(i));
      readers.push_back(r);
    }
    for (const auto& [key, name] : topics.nodes) {
      if (!result) break;
      const int head = topics.heads[key];
      if (head < 0 || writers.count(name) != 0) continue;
      const dds_topic_descriptor_t* desc = &sensor_msgs_msg_dds__Image__desc;
      switch (output_kind(scenario.model.heads[static_cast<std::size_t>(head)])) {
        case OutputKind::Velocity:
          desc = &geometry_msgs_msg_dds__Twist__desc;
          break;
        case OutputKind::Detections:
          desc = &vision_msgs_msg_dds__Detection2DArray__desc;
          break;
        case OutputKind::Mask:
          break;
      }
      const dds_entity_t topic =
          dds_create_topic(pp, desc, dds_topic_name(name).c_str(), nullptr, nullptr);
      const dds_entity_t w = topic < 0 ? topic : dds_create_writer(pp, topic, out_qos, nullptr);
      if (w < 0) {
        result =
            fail("cannot publish " + name + " (is it remapped onto a topic of another type?)", w);
        break;
      }
      writers[name] = w;
      if (desc == &geometry_msgs_msg_dds__Twist__desc) {
        // Twist has no header: the same values with the frame's header beside it.
        const std::string stamped = name + "/stamped";
        const dds_entity_t st = dds_create_topic(pp, &geometry_msgs_msg_dds__TwistStamped__desc,
                                                 dds_topic_name(stamped).c_str(), nullptr, nullptr);
        const dds_entity_t sw = st < 0 ? st : dds_create_writer(pp, st, out_qos, nullptr);
        if (sw < 0) {
          result = fail("cannot publish " + stamped, sw);
          break;
        }
        writers[stamped] = sw;
      }
    }
    if (result) {
      const dds_entity_t topic =
          dds_create_topic(pp, &diagnostic_msgs_msg_dds__DiagnosticArray__desc,
                           dds_topic_name(topics.diagnostics).c_str(), nullptr, nullptr);
      diag_writer = topic < 0 ? topic : dds_create_writer(pp, topic, out_qos, nullptr);
      if (diag_writer < 0) result = fail("cannot publish " + topics.diagnostics, diag_writer);
    }
    dds_delete_qos(in_qos);
    dds_delete_qos(out_qos);
    return result;
  }

  // ---- receiving: frame arrivals are releases ----

  void reject(std::size_t sensor, Reject why, const Image& img) {
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
  static void on_unmatched_writer(dds_entity_t, const dds_requested_incompatible_qos_status_t st,
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
  void count_undelivered(std::size_t sensor, Reject why, std::int64_t change) {
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

  static void on_sample_lost(dds_entity_t, const dds_sample_lost_status_t st, void* arg) {
    const ReaderCtx& ctx = *static_cast<const ReaderCtx*>(arg);
    if (ctx.impl != nullptr)
      ctx.impl->count_undelivered(ctx.sensor, Reject::LostInTransport, st.total_count_change);
  }

  static void on_sample_rejected(dds_entity_t, const dds_sample_rejected_status_t st, void* arg) {
    const ReaderCtx& ctx = *static_cast<const ReaderCtx*>(arg);
    if (ctx.impl != nullptr)
      ctx.impl->count_undelivered(ctx.sensor, Reject::RejectedByDds, st.total_count_change);
  }

  static void record(std::vector<double>& ring, std::uint64_t n, double v) {
    if (ring.size() < kIntakeWindow)
      ring.push_back(v);
    else
      ring[n % kIntakeWindow] = v;
  }

  // A checked frame is a release (docs/ROS2.md): the pixels are moved out of the sample, not
  // converted; the backend gets them as a LazyFrame that converts them to the model's input
  // when a unit first needs them (the encoder's start), so a frame whose job is dropped
  // before it runs is never converted. Only after the release is the frame's luminance (what
  // the outputs are computed from) converted, here, off the release path.
  void accept(std::size_t sensor, Image& img, TimePoint taken, WallStamp taken_wall) {
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
      const double transport =
          (static_cast<double>(taken_wall.sec - img.header_.stamp_.sec_) * 1e9 +
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

  void receive_main() {
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

  // ---- observing the runtime (called with the scheduler's lock held) ----

  void on_unit_end(const Dispatch& d, TimePoint, UnitStatus s) override {
    if (s != UnitStatus::Completed) return;
    for (const Member& m : d.members) {
      if (m.graph == nullptr || m.unit < 0) continue;
      const RefinedUnit& u = m.graph->units[static_cast<std::size_t>(m.unit)];
      for (int n : u.produces) {
        const NodeSpec& spec = m.graph->spec->nodes[static_cast<std::size_t>(n)];
        if (spec.head < 0) continue;
        finished_heads[m.job].push_back(
            {m.operation, spec.name, spec.head, spec.sensor, m.frame, TimePoint{0}});
      }
    }
  }

  // A job released on the receiving thread while it pushes a frame is that frame's release
  // (the runtime released it there, holding the scheduler's lock): the first one stamps it.
  void on_job_release(const JobRecord&) override {
    if (pushing_node == this && !released_at) released_at = clock.now();
  }

  void on_job_end(const JobRecord& j) override {
    std::vector<Output> outs;
    if (auto it = finished_heads.find(j.id); it != finished_heads.end()) {
      outs = std::move(it->second);
      finished_heads.erase(it);
    }
    const bool completed = j.outcome == JobOutcome::Met || j.outcome == JobOutcome::Missed;
    {
      std::lock_guard lock(stats_mu);
      OpStats& st = stats[static_cast<std::size_t>(j.operation)];
      if (j.outcome != JobOutcome::Unfinished) ++st.jobs;
      if (completed) {
        ++st.completed;
        const Duration r = j.finish - j.release;
        st.qoe_sum += qoe_score(r, j.deadline - j.release, scenario.scheduler.qoe_lambda);
        const double ms = to_ms(r);
        if (st.latency_ms.size() < kLatencyWindow)
          st.latency_ms.push_back(ms);
        else
          st.latency_ms[st.next++ % kLatencyWindow] = ms;
      }
      if (j.outcome == JobOutcome::Missed) ++st.missed;
      if (j.outcome == JobOutcome::Dropped || j.outcome == JobOutcome::Skipped ||
          j.outcome == JobOutcome::Failed) {
        ++st.missed;
        ++st.dropped;
      }
    }
    // A finished job publishes what it computed; a dropped one (strict) nothing (docs/ROS2.md).
    if (!completed) {
      std::lock_guard lock(counters_mu);
      if (j.outcome != JobOutcome::Unfinished) ++counters.jobs_without_output;
      return;
    }
    {
      const TimePoint now = clock.now();
      std::lock_guard lock(pub_mu);
      for (Output& o : outs) {
        o.ended = now;
        queue.push_back(std::move(o));
      }
    }
    pub_cv.notify_one();
  }

  // ---- publishing ----

  // The frame a head read, if still kept: its header and (shared, not copied) luminance.
  bool frame_of(const Output& o, HeaderValue& header, std::shared_ptr<const ConvertedImage>& gray,
                std::optional<FrameStats>& fs) {
    std::lock_guard lock(frames_mu);
    const FrameSlot& slot = sensors[static_cast<std::size_t>(o.sensor)].ring[o.frame % kFrameRing];
    if (slot.id != o.frame || !slot.gray) return false;
    header = slot.header;
    gray = slot.gray;
    fs = slot.stats;
    return true;
  }

  // The published values are computed from the frame by fixed rules (the built-in model's
  // weights are random, docs/DESIGN.md, "Built-in model"): lane a bright-pixel mask, seg four
  // luminance classes, steer the left/right balance, det the box around the brightest pixels.
  void publish(const Output& o, const FrameView& g, const FrameStats& f, const HeaderValue& hv) {
    const std::string& head = scenario.model.heads[static_cast<std::size_t>(o.head)];
    const auto topic = topics.nodes.find(std::make_pair(o.operation, o.node));
    if (topic == topics.nodes.end()) return;
    const auto wit = writers.find(topic->second);
    if (wit == writers.end()) return;
    const std::size_t n_px = static_cast<std::size_t>(g.width) * static_cast<std::size_t>(g.height);
    switch (output_kind(head)) {
      case OutputKind::Mask: {
        // Computed into the publisher's own buffer; dds_write serializes it (its one copy).
        mask.resize(n_px);
        if (head == "seg") {
          for (std::size_t i = 0; i < n_px; ++i)
            mask[i] = static_cast<std::uint8_t>(g.data[i] / 64);
        } else {
          // An integer pixel is above the mean exactly when it is above its floor.
          const auto above = static_cast<std::uint8_t>(std::min(255.0, std::floor(f.mean)));
          for (std::size_t i = 0; i < n_px; ++i)
            mask[i] = static_cast<std::uint8_t>(g.data[i] > above ? 255 : 0);
        }
        Image m{};
        hv.fill(m.header_);
        m.height_ = static_cast<std::uint32_t>(g.height);
        m.width_ = static_cast<std::uint32_t>(g.width);
        m.encoding_ = const_cast<char*>("mono8");
        m.step_ = static_cast<std::uint32_t>(g.width);
        borrow(m.data_, mask);
        dds_write(wit->second, &m);
        std::lock_guard lock(counters_mu);
        ++counters.masks;
        break;
      }
      case OutputKind::Velocity: {
        const double half = std::max(1.0, static_cast<double>(g.width * g.height) / 2.0);
        Twist t{};
        t.linear_.x_ = f.mean / 255.0;
        t.angular_.z_ = (f.right - f.left) / half / 255.0;
        dds_write(wit->second, &t);
        if (const auto sit = writers.find(wit->first + "/stamped"); sit != writers.end()) {
          TwistStamped ts{};
          hv.fill(ts.header_);
          ts.twist_ = t;
          dds_write(sit->second, &ts);
        }
        std::lock_guard lock(counters_mu);
        ++counters.twists;
        break;
      }
      case OutputKind::Detections: {
        const int x0 = f.x0, y0 = f.y0, x1 = f.x1, y1 = f.y1, n = f.bright;
        Detection2DArray a{};
        hv.fill(a.header_);
        std::vector<Detection2D> dets;
        std::vector<ObjectHypothesisWithPose> hyp(1);
        const std::string cls = "bright", id;
        if (n > 0) {
          const double area = static_cast<double>((x1 - x0 + 1) * (y1 - y0 + 1));
          hyp[0].hypothesis_.class_id_ = borrow(cls);
          hyp[0].hypothesis_.score_ = static_cast<double>(n) / area;
          hyp[0].pose_.pose_.orientation_.w_ = 1.0;
          Detection2D d{};
          hv.fill(d.header_);
          borrow(d.results_, hyp);
          d.bbox_.center_.position_.x_ = (x0 + x1) / 2.0;
          d.bbox_.center_.position_.y_ = (y0 + y1) / 2.0;
          d.bbox_.size_x_ = x1 - x0 + 1;
          d.bbox_.size_y_ = y1 - y0 + 1;
          d.id_ = borrow(id);
          dets.push_back(d);
        }
        borrow(a.detections_, dets);
        dds_write(wit->second, &a);
        std::lock_guard lock(counters_mu);
        ++counters.detections;
        break;
      }
    }
  }

  void publish_diagnostics() {
    for (double v : runtime->decision_us_since(decisions_seen)) {
      if (decisions_us.size() < kDecisionWindow)
        decisions_us.push_back(v);
      else
        decisions_us[decision_slot++ % kDecisionWindow] = v;
    }
    std::deque<std::string> text;  // what the message borrows
    const auto s = [&text](std::string v) { return borrow(text.emplace_back(std::move(v))); };
    std::vector<DiagnosticStatus> status;
    std::deque<std::vector<KeyValue>> values;
    const auto add = [&](std::uint8_t level, const std::string& name, const std::string& message,
                         const std::vector<std::pair<std::string, std::string>>& kv) {
      auto& v = values.emplace_back();
      for (const auto& [k, x] : kv) v.push_back({s(k), s(x)});
      DiagnosticStatus st{};
      st.level_ = level;
      st.name_ = s(name);
      st.message_ = s(message);
      st.hardware_id_ = s("red");
      borrow(st.values_, v);
      status.push_back(st);
    };
    {
      std::lock_guard lock(stats_mu);
      for (std::size_t i = 0; i < stats.size(); ++i) {
        const OpStats& st = stats[i];
        const double jobs = static_cast<double>(std::max<std::uint64_t>(1, st.jobs));
        const double miss = static_cast<double>(st.missed) / jobs;
        std::vector<double> lat = st.latency_ms;
        std::sort(lat.begin(), lat.end());
        add(miss > 0.05 ? 1 : 0, "red: " + scenario.operation_name(static_cast<int>(i)),
            miss > 0.05 ? "missing deadlines" : "ok",
            {{"jobs", std::to_string(st.jobs)},
             {"completed", std::to_string(st.completed)},
             {"miss_rate", fmt_double(miss)},
             {"drop_rate", fmt_double(static_cast<double>(st.dropped) / jobs)},
             {"qoe", fmt_double(st.jobs == 0 ? 0.0 : st.qoe_sum / jobs)},
             {"latency_p50_ms", fmt_double(percentile_sorted(lat, 0.5))},
             {"latency_p99_ms", fmt_double(percentile_sorted(lat, 0.99))}});
      }
    }
    std::string silent;
    std::vector<char> is_silent(sensors.size(), 0);
    NodeCounters c;
    {
      std::lock_guard lock(counters_mu);
      c = counters;
    }
    {
      std::lock_guard lock(frames_mu);
      const TimePoint now = clock.now();
      for (std::size_t i = 0; i < sensors.size(); ++i) {
        const double rate = scenario.sensors[i].rate_hz;
        const Duration quiet{static_cast<std::int64_t>(options.silent_periods / rate * 1e9)};
        if (sensors[i].last && now - *sensors[i].last <= quiet) continue;
        is_silent[i] = 1;
        silent += (silent.empty() ? "" : ",") + scenario.sensors[i].name;
      }
    }
    // A sensor that is silent though a writer is matched on its topic: its frames are sent
    // but do not arrive whole (too large for the transport, most often).
    // Two diagnostics in a row (a second), so that a writer matched just before it starts
    // publishing is not taken for one whose frames are lost.
    std::string matched_but_silent;
    matched_silent_ticks.resize(readers.size(), 0);
    for (std::size_t i = 0; i < readers.size(); ++i) {
      dds_subscription_matched_status_t st{};
      const bool now_silent =
          is_silent[i] != 0 &&
          dds_get_subscription_matched_status(readers[i], &st) == DDS_RETCODE_OK &&
          st.current_count > 0;
      matched_silent_ticks[i] = now_silent ? matched_silent_ticks[i] + 1 : 0;
      if (matched_silent_ticks[i] >= 2)
        matched_but_silent += (matched_but_silent.empty() ? "" : ",") + topics.sensors[i];
    }
    std::vector<double> dec = decisions_us;
    std::vector<std::pair<std::string, std::string>> kv = {
        {"policy", options.policy},
        {"decision_p99_us", fmt_double(percentile(dec, 0.99))},
        {"frames", std::to_string(c.frames)},
        {"released", std::to_string(c.released)},
        {"silent_sensors", silent}};
    std::uint64_t rejected = 0;
    for (int r = 0; r < kRejectKinds; ++r) {
      rejected += c.rejected[static_cast<std::size_t>(r)];
      kv.emplace_back(std::string("rejected_") + to_string(static_cast<Reject>(r)),
                      std::to_string(c.rejected[static_cast<std::size_t>(r)]));
    }
    kv.emplace_back("matched_but_silent", matched_but_silent);
    add(silent.empty() && rejected == 0 ? 0 : 1, "red: node",
        silent.empty() ? "ok"
        : matched_but_silent.empty()
            ? "silent sensor(s): " + silent
            : "silent sensor(s): " + silent + "; a writer is matched on " + matched_but_silent +
                  " but no frame arrives whole (too large for the "
                  "transport? docs/ROS2.md, Large frames)",
        kv);
    if (!matched_but_silent.empty() && !warned_matched_but_silent.exchange(true))
      std::cerr << "red node: a writer is matched on " << matched_but_silent
                << " but no frame arrives whole: frames too large for the transport are lost "
                   "(docs/ROS2.md, \"Large frames\")\n";
    DiagnosticArray a{};
    stamp_now(a.header_.stamp_.sec_, a.header_.stamp_.nanosec_);
    a.header_.frame_id_ = s("");
    borrow(a.status_, status);
    dds_write(diag_writer, &a);
    std::lock_guard lock(counters_mu);
    ++counters.diagnostics;
  }

  void publish_main() {
    TimePoint next_diag = clock.now() + options.diagnostics_period;
    HeaderValue header;
    std::shared_ptr<const ConvertedImage> gray;
    std::optional<FrameStats> fs;
    for (;;) {
      std::optional<Output> item;
      bool done = false;
      double woke_us = -1;  // queued -> taken here, when this thread waited for it
      {
        std::unique_lock lock(pub_mu);
        const bool waits = queue.empty();
        const auto wall = std::chrono::steady_clock::now() + (next_diag - clock.now());
        pub_cv.wait_until(lock, wall, [&] { return !queue.empty() || !publishing; });
        if (!queue.empty()) {
          item = std::move(queue.front());
          queue.pop_front();
          if (waits) woke_us = to_us(clock.now() - item->ended);
        } else {
          done = !publishing;
        }
      }
      if (item) {
        if (woke_us >= 0) {
          std::lock_guard lock(counters_mu);
          record(timings.publish_wake_us, publish_wakes++, woke_us);
        }
        if (frame_of(*item, header, gray, fs)) {
          const FrameView g = gray->pixels();
          // Computed after the release unless this job ended first (then here, alike).
          if (!fs) fs = frame_stats(g);
          publish(*item, g, *fs, header);
          gray.reset();
          const double us = to_us(clock.now() - item->ended);
          std::lock_guard lock(counters_mu);
          record(timings.publish_us, publishes++, us);
        } else {
          std::lock_guard lock(counters_mu);
          ++counters.jobs_without_output;  // its frame left the ring: never a wrong stamp
        }
      }
      if (done || clock.now() >= next_diag) {
        publish_diagnostics();
        next_diag = clock.now() + options.diagnostics_period;
      }
      if (done) return;
    }
  }

  // With --realtime the node's own threads run under SCHED_FIFO as the runtime's do (a
  // frame is a release: the receiver at the synchronizer's priority, one above the
  // handlers'; the publisher below the handlers, so that it never delays a decision).
  // Otherwise any process on the machine can keep a frame or an output waiting for
  // milliseconds. Best effort: the runtime reports whether SCHED_FIFO is permitted.
  void make_realtime(std::thread& t, int priority) const {
    if (!options.realtime) return;
    sched_param sp{};
    sp.sched_priority = std::max(1, priority);
    (void)pthread_setschedparam(t.native_handle(), SCHED_FIFO, &sp);
  }

  RuntimeReport run() {
    std::thread receiver([this] { receive_main(); });
    std::thread publisher([this] { publish_main(); });
    make_realtime(receiver, RuntimeOptions{}.rt_priority + 1);
    make_realtime(publisher, RuntimeOptions{}.rt_priority - 1);
    RuntimeReport report = runtime->run();
    receiving.store(false, std::memory_order_release);
    dds_set_guardcondition(wake, true);
    receiver.join();
    {
      std::lock_guard lock(pub_mu);
      publishing = false;
    }
    pub_cv.notify_one();
    publisher.join();
    return report;
  }
};

Expected<std::unique_ptr<Node>> Node::make(const Scenario& scenario, const Profile& profile,
                                           Backend& backend, NodeOptions options) {
  // The scenario's policy options (and the CLI's --with) apply, as in red run.
  auto policy = make_policy(options.policy, policy_options(scenario, options.policy));
  if (!policy) return Error{"", 0, "unknown policy '" + options.policy + "'"};
  auto impl = std::make_unique<Impl>(scenario, profile, backend, std::move(options));
  if (auto r = impl->open(); !r) return r.error();
  RuntimeOptions ro;
  ro.realtime = impl->options.realtime;
  ro.external_frames = true;
  ro.watchdog_x = impl->options.watchdog_x;
  impl->runtime =
      std::make_unique<Runtime>(impl->scenario, profile, std::move(policy), backend, ro);
  impl->runtime->add_observer(impl.get());
  return std::unique_ptr<Node>(new Node(std::move(impl)));
}

Node::Node(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Node::~Node() = default;

RuntimeReport Node::run() {
  return impl_->run();
}

void Node::add_observer(Observer* o) {
  impl_->runtime->add_observer(o);
}

void Node::stop() {
  impl_->runtime->stop();
}

NodeCounters Node::counters() const {
  std::lock_guard lock(impl_->counters_mu);
  return impl_->counters;
}

Node::Timings Node::timings() const {
  std::lock_guard lock(impl_->counters_mu);
  Timings t = impl_->timings;
  t.released_intake_us = impl_->released_intake_us;
  t.taken_released_us = impl_->taken_released_us;
  return t;
}

const NodeTopics& Node::topics() const {
  return impl_->topics;
}

}  // namespace red::dds
