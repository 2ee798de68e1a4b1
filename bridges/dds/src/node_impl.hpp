#pragma once
// The node's private parts (Node::Impl), one file per part (docs/ARCHITECTURE.md): node.cpp the DDS
// plumbing and the run, node_intake.cpp frame intake (frame arrivals are releases),
// node_outputs.cpp the runtime's observer and the head outputs' publishing,
// node_diagnostics.cpp the /diagnostics message.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "red/core/clock.hpp"
#include "red/core/newest.hpp"
#include "red/dds/node.hpp"
#include "red/metrics/tally.hpp"

namespace red::dds {

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

FrameStats frame_stats(const FrameView& g);

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

// An operation's ended jobs: what counts as a miss and how QoE is averaged are the metrics
// module's (OutcomeTally, as in red run's summary); the latencies are the node's own window.
struct OpStats {
  OutcomeTally tally;
  // Jobs not met, by cause as a job's end tells it: "late" (it finished after its deadline), or
  // the rule that shed it (its reason: "rejected at release", "hopeless", "max_inflight",
  // "deadline passed", a failure's). Why a late job was late (the lane time before it) is in
  // jobs.csv's cause at the end (--out).
  std::map<std::string, std::uint64_t> not_met;
  std::vector<double> latency_ms;  // the newest kLatencyWindow (keep_newest)
  std::uint64_t completed = 0;     // latencies offered to it
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
inline thread_local const void* pushing_node = nullptr;

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
  std::uint64_t decisions_kept = 0;  // decision times offered to decisions_us (keep_newest)

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

  Impl(const Scenario& s, const Profile& p, Backend& b, NodeOptions o);
  ~Impl() override;

  Expected<bool> open();

  // ---- receiving: frame arrivals are releases (node_intake.cpp) ----

  void reject(std::size_t sensor, Reject why, const Image& img);
  static void on_unmatched_writer(dds_entity_t, const dds_requested_incompatible_qos_status_t st,
                                  void* arg);
  void count_undelivered(std::size_t sensor, Reject why, std::int64_t change);
  static void on_sample_lost(dds_entity_t, const dds_sample_lost_status_t st, void* arg);
  static void on_sample_rejected(dds_entity_t, const dds_sample_rejected_status_t st, void* arg);

  static void record(std::vector<double>& ring, std::uint64_t n, double v) {
    keep_newest(ring, n, kIntakeWindow, v);
  }

  void accept(std::size_t sensor, Image& img, TimePoint taken, WallStamp taken_wall);
  void receive_main();

  // ---- observing the runtime, called with the scheduler's lock held (node_outputs.cpp) ----

  void on_unit_end(const Dispatch& d, TimePoint, UnitStatus s) override;
  void on_job_release(const JobRecord&) override;
  void on_job_end(const JobRecord& j) override;

  // ---- publishing (node_outputs.cpp; the diagnostics: node_diagnostics.cpp) ----

  bool frame_of(const Output& o, HeaderValue& header, std::shared_ptr<const ConvertedImage>& gray,
                std::optional<FrameStats>& fs);
  void publish(const Output& o, const FrameView& g, const FrameStats& f, const HeaderValue& hv);
  void publish_diagnostics();
  void publish_main();

  // ---- running (node.cpp) ----

  void make_realtime(std::thread& t, int priority) const;
  RuntimeReport run();
};

}  // namespace red::dds
