/// \file
/// Example: RED's real-time runtime on your own inference backend.
///
/// An inference runtime you already have (TensorRT, ONNX Runtime, your own CUDA code) is
/// stood in for by a thread pool that calls a user function per unit. PoolBackend
/// implements red::Backend on top of it; a two-operation workload is built in code with
/// red::ScenarioBuilder (no YAML); red::Runtime schedules it with the `red` policy in real
/// time; a red::MetricsCollector observes the run and the summary is printed.
///
/// With --async the same user function runs on asynchronous lanes (StreamBackend), as a
/// GPU runtime runs units on streams: RED enqueues a unit, queues the lane's next one while
/// it runs, and waits for each in turn (red::Backend::enqueue and wait).
///
///     custom_backend [seconds] [--async]   # default 1 s of releases, then draining
///
/// Built against the installed package: see CMakeLists.txt next to this file.

#include <red/metrics/metrics.hpp>
#include <red/profile/profile.hpp>
#include <red/runtime/backend.hpp>
#include <red/runtime/runtime.hpp>
#include <red/scenario/builder.hpp>
#include <red/sched/policy.hpp>
#include <red/version.hpp>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <deque>
#include <functional>
#include <future>
#include <iostream>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace {

using std::chrono::microseconds;
using std::chrono::milliseconds;

/// A fixed-size thread pool: the executor of the inference runtime being embedded.
class ThreadPool {
 public:
  explicit ThreadPool(int threads) {
    for (int i = 0; i < threads; ++i) workers_.emplace_back([this] { work(); });
  }
  ~ThreadPool() {
    {
      std::lock_guard lock(mu_);
      stop_ = true;
    }
    cv_.notify_all();
    for (auto& w : workers_) w.join();
  }
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  /// Queues `f`; the future holds its exception, if it throws.
  std::future<void> submit(std::function<void()> f) {
    std::packaged_task<void()> task(std::move(f));
    std::future<void> done = task.get_future();
    {
      std::lock_guard lock(mu_);
      queue_.push_back(std::move(task));
    }
    cv_.notify_one();
    return done;
  }

 private:
  void work() {
    for (;;) {
      std::packaged_task<void()> task;
      {
        std::unique_lock lock(mu_);
        cv_.wait(lock, [this] { return stop_ || !queue_.empty(); });
        if (queue_.empty()) return;  // stopping, nothing left
        task = std::move(queue_.front());
        queue_.pop_front();
      }
      task();
    }
  }

  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<std::packaged_task<void()>> queue_;
  bool stop_ = false;
  std::vector<std::thread> workers_;
};

/// What the user function is asked to compute for one dispatched unit.
struct UnitWork {
  red::UnitKind kind = red::UnitKind::Plain;
  std::string head;      ///< model head for Head/Coarse units, else empty
  int lane = 0;          ///< RED's lane the unit was dispatched to
  int batch = 1;         ///< tasks run as one batch (distinct frames or jobs)
  std::size_t jobs = 1;  ///< (job, node) pairs the unit serves (merged encoder runs share)
};

/// What a dispatch asks of the user function.
UnitWork work_of(const red::Scenario& s, int lane, const red::Dispatch& d) {
  UnitWork w;
  w.kind = d.kind;
  if (d.head >= 0) w.head = s.model.heads[static_cast<std::size_t>(d.head)];
  w.lane = lane;
  w.batch = d.batch;
  w.jobs = d.members.size();
  return w;
}

/// red::Backend on a thread pool. RED calls run() on the lane's own thread, one unit at a
/// time per lane; it hands the unit to the pool and blocks until the pool ran it, so RED's
/// lane stays busy exactly as long as the unit runs. An exception from the user function
/// comes back through the future and makes the runtime record a failed job.
class PoolBackend final : public red::Backend {
 public:
  PoolBackend(const red::Scenario& s, ThreadPool& pool, std::function<void(const UnitWork&)> fn)
      : scenario_(s), pool_(pool), fn_(std::move(fn)) {}

  [[nodiscard]] std::string_view name() const noexcept override { return "thread pool"; }

  void run(int lane, const red::Dispatch& d) override {
    const UnitWork w = work_of(scenario_, lane, d);
    pool_.submit([this, w] { fn_(w); }).get();  // rethrows what the user function threw
    units_.fetch_add(1, std::memory_order_relaxed);
  }

  /// Units run so far.
  [[nodiscard]] std::uint64_t units() const noexcept { return units_.load(); }

 private:
  const red::Scenario& scenario_;
  ThreadPool& pool_;
  std::function<void(const UnitWork&)> fn_;
  std::atomic<std::uint64_t> units_{0};
};

/// The same user function on asynchronous lanes, as a GPU inference runtime runs units on
/// streams: each lane is a queue served by one thread (a "stream": its units run in the
/// order given). enqueue() hands the unit over and returns at once; wait() takes the oldest
/// unit's outcome, with when it started and ended. RED's on-demand policies then queue a
/// lane's next unit shortly before the one running ends (docs/GPU.md, "Asynchronous
/// lanes"). enqueue() and wait() are called from the lane's own thread, so the per-lane
/// list of pending units needs no lock.
class StreamBackend final : public red::Backend {
 public:
  StreamBackend(const red::Scenario& s, std::function<void(const UnitWork&)> fn)
      : scenario_(s), fn_(std::move(fn)) {
    for (int l = 0; l < s.device.lanes; ++l) lanes_.push_back(std::make_unique<Lane>());
  }

  [[nodiscard]] std::string_view name() const noexcept override { return "lane streams"; }
  [[nodiscard]] bool asynchronous() const noexcept override { return true; }

  void enqueue(int lane, const red::Dispatch& d) override {
    const UnitWork w = work_of(scenario_, lane, d);
    auto done = std::make_shared<red::UnitDone>();
    Lane& l = *lanes_[static_cast<std::size_t>(lane)];
    l.pending.emplace_back(done, l.stream.submit([this, w, done] {
      done->started = std::chrono::steady_clock::now();
      fn_(w);
      done->ended = std::chrono::steady_clock::now();
    }));
  }

  red::UnitDone wait(int lane) override {
    Lane& l = *lanes_[static_cast<std::size_t>(lane)];
    auto [done, finished] = std::move(l.pending.front());
    l.pending.pop_front();
    try {
      finished.get();  // rethrows what the user function threw: the unit failed
    } catch (const std::exception& e) {
      done->status = red::UnitStatus::Failed;
      done->reason = e.what();
    }
    units_.fetch_add(1, std::memory_order_relaxed);
    return *done;
  }

  // Never called on an asynchronous backend; runs one unit to its end all the same.
  void run(int lane, const red::Dispatch& d) override {
    enqueue(lane, d);
    const red::UnitDone done = wait(lane);
    if (done.status != red::UnitStatus::Completed) throw std::runtime_error(done.reason);
  }

  /// Units run so far.
  [[nodiscard]] std::uint64_t units() const noexcept { return units_.load(); }

 private:
  struct Lane {
    ThreadPool stream{1};
    std::deque<std::pair<std::shared_ptr<red::UnitDone>, std::future<void>>> pending;
  };
  const red::Scenario& scenario_;
  std::function<void(const UnitWork&)> fn_;
  std::vector<std::unique_ptr<Lane>> lanes_;
  std::atomic<std::uint64_t> units_{0};
};

// What each unit costs on this "device". The user function spends it, and the profile
// below tells RED's deadline arithmetic the same figures (in a real integration: measure
// them, e.g. with `red profile` or from a run's units.csv).
constexpr microseconds kEncoderCost{1500};
constexpr microseconds kHeadCost{500};

/// The user function: "runs inference" by spending the unit's cost.
void infer(const UnitWork& w) {
  microseconds cost = w.kind == red::UnitKind::Encoder ? kEncoderCost : kHeadCost;
  if (w.kind == red::UnitKind::Coarse || w.kind == red::UnitKind::Mono) cost += kEncoderCost;
  std::this_thread::sleep_for(cost);
}

/// A profile describing the user function's costs: encoder, head/<h> and coarse/<h>.
red::Profile profile_of_this_device(const red::Scenario& s) {
  auto fixed = [](red::Duration d) {
    red::LatencyStats st;
    st.min = st.mean = st.p50 = st.p95 = st.p99 = st.max = d;
    red::UnitProfile u;
    u.by_batch.push_back(st);
    return u;
  };
  red::Profile p;
  p.source = "measured";
  p.device = "thread pool (example)";
  p.model = "user model";
  p.sync_round_trip = microseconds{50};
  p.units["encoder"] = fixed(kEncoderCost);
  for (const std::string& h : s.model.heads) {
    p.units["head/" + h] = fixed(kHeadCost);
    p.units["coarse/" + h] = fixed(kEncoderCost + kHeadCost);
  }
  return p;
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 1.0;
  const bool async = argc > 2 && std::string(argv[2]) == "--async";
  if (argc > 3 || (argc > 2 && !async)) {
    std::cerr << "usage: custom_backend [seconds] [--async]\n";
    return 2;
  }
  if (argc > 1) {
    char* end = nullptr;
    seconds = std::strtod(argv[1], &end);
    if (end == argv[1] || *end != '\0' || !(seconds > 0.0 && seconds <= 3600.0)) {
      std::cerr << "custom_backend: seconds must be a number in (0, 3600], not '" << argv[1]
                << "'\n";
      return 2;
    }
  }

  // The workload, in code: a camera at 30 Hz; "perceive" runs the lane head then the
  // segmentation head on every frame (two heads sharing one encoder run); "plan" is a
  // plain 2 ms task at its own 10 Hz.
  red::ScenarioBuilder b("custom-backend");
  b.duration(std::chrono::duration_cast<red::Duration>(std::chrono::duration<double>(seconds)))
      .lanes(2)
      .heads({"lane", "seg"})
      .sensor("camera", 30.0);
  b.operation("perceive")
      .trigger("camera")
      .deadline(milliseconds{20})
      .inference("L", "lane", "camera")
      .inference("S", "seg", "camera")
      .edge("L", "S");
  b.operation("plan").rate(10.0).deadline(milliseconds{15}).plain("P", milliseconds{2});
  red::Expected<red::Scenario> scenario = b.build();
  if (!scenario) {
    std::cerr << scenario.error().to_string() << '\n';
    return 2;
  }
  const red::Profile profile = profile_of_this_device(*scenario);

  ThreadPool pool(2);
  PoolBackend pooled(*scenario, pool, infer);
  StreamBackend streams(*scenario, infer);
  red::Backend& backend = async ? static_cast<red::Backend&>(streams) : pooled;

  red::RuntimeOptions options;
  options.realtime = false;      // no SCHED_FIFO / mlockall needed for an example
  options.interference = false;  // the scenario has none anyway
  red::Runtime runtime(*scenario, profile, red::make_policy("red"), backend, options);
  red::MetricsCollector metrics(*scenario, scenario->scheduler.qoe_lambda, false);
  runtime.add_observer(&metrics);

  const red::RuntimeReport report = runtime.run();
  red::PolicyMetrics m = metrics.summarize("red", report.end);

  std::cout << "RED " << red::kVersion << " on backend '" << backend.name()
            << "': " << (async ? streams.units() : pooled.units()) << " units run, "
            << report.failures << " failed";
  if (async) std::cout << ", " << report.enqueued_ahead << " queued behind a running unit";
  std::cout << "\n";
  std::cout << "jobs " << m.jobs << ", completed " << m.completed << ", met " << m.met
            << ", missed " << m.missed << ", dropped " << m.dropped << "\n"
            << "miss rate " << m.miss_rate << ", QoE " << m.qoe << ", latency mean "
            << m.latency.mean << " ms, p99 " << m.latency.p99 << " ms\n"
            << "encoder runs " << m.encoder_runs << " (" << m.encoder_runs_saved
            << " saved by merging)\n";
  return m.completed > 0 && report.failures == 0 ? 0 : 1;
}
