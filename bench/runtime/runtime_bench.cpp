/// \file
/// `red_runtime_bench`: the real-time runtime measured on the wall clock (docs/DESIGN.md,
/// "Performance targets"), with the synthetic backend (units spin for their profiled time) so only
/// the scheduler and the synchronizers are measured, not a network:
///  - unit completion -> next unit started on that lane (p50, p99), per-edge vs on-demand;
///  - synchronizer round trips and decisions taken locally by handlers;
///  - scheduling decision time inside the runtime;
///  - heap held by the scheduler and synchronizers (glibc mallinfo2, before vs after);
///  - with RED_EXTERNAL_FRAMES=1, frames pushed by one feeder thread per sensor
///    (Runtime::push_frame, as the DDS node does) instead of the runtime's camera: frame
///    pushed -> job released (p50, p99) and how many were released by the pushing thread
///    (feeders at SCHED_FIFO with RED_REALTIME=1, unless RED_FEEDER_OTHER=1).
///
///     [RED_REALTIME=1] [RED_EXTERNAL_FRAMES=1] build/bench/red_runtime_bench [scenario.yaml]
///         [seconds]

#include <malloc.h>
#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include "red/metrics/metrics.hpp"
#include "red/runtime/runtime.hpp"
#include "red/runtime/synthetic_backend.hpp"
#include "red/scenario/loader.hpp"
#include "red/sim/run.hpp"

namespace {

std::size_t heap_in_use() {
  return mallinfo2().uordblks;
}

// Counts outcomes without allocating, so the heap measured is the runtime's own.
struct Outcomes final : red::Observer {
  long long jobs = 0, missed = 0, completed = 0;
  double latency_ms = 0;
  void on_job_end(const red::JobRecord& j) override {
    if (!j.counted || j.outcome == red::JobOutcome::Unfinished) return;
    ++jobs;
    const bool done = j.outcome == red::JobOutcome::Met || j.outcome == red::JobOutcome::Missed;
    if (j.outcome != red::JobOutcome::Met) ++missed;
    if (done) {
      ++completed;
      latency_ms += red::to_ms(j.finish - j.release);
    }
  }
};

}  // namespace

int main(int argc, char** argv) {
  const std::string path = argc > 1 ? argv[1] : RED_SOURCE_DIR "/scenarios/minibench-tight.yaml";
  const double seconds = argc > 2 ? std::atof(argv[2]) : 5.0;
  auto s = red::load_scenario(path);
  if (!s) {
    std::fprintf(stderr, "%s\n", s.error().to_string().c_str());
    return 2;
  }
  if (auto e = red::apply_override(*s, "duration_s", seconds)) {
    // Scenarios with events late in their timeline keep their own duration.
    std::fprintf(stderr, "note: %s; running the scenario's full duration\n",
                 e->to_string().c_str());
  }
  auto p = red::resolve_profile(*s, std::nullopt);
  if (!p) {
    std::fprintf(stderr, "%s\n", p.error().to_string().c_str());
    return 2;
  }
  struct Variant {
    const char* label;
    const char* policy;
    red::SyncMode sync;
  };
  const Variant variants[] = {{"red, on-demand", "red", red::SyncMode::OnDemand},
                              {"red, per-edge", "red", red::SyncMode::PerEdge},
                              {"edf, per-edge", "edf", red::SyncMode::PerEdge}};
  std::printf("scenario %s, %.1f s of real time per variant, synthetic backend (spinning)\n",
              s->name.c_str(), red::to_s(s->duration));
  const bool external = std::getenv("RED_EXTERNAL_FRAMES") != nullptr;
  std::printf("%-16s %6s %9s %9s %9s %9s %8s %8s %9s %10s %9s %8s %8s %8s\n", "variant", "jobs",
              "miss%", "mean ms", "hand p50", "hand p99", "rtrips", "local", "dec p50", "dec p99",
              "heap KB", "rel p50", "rel p99", "direct");
  for (const Variant& v : variants) {
    auto o = red::preset_options(v.policy);
    o->sync = v.sync;
    red::SyntheticBackend::Options so;
    so.spin = true;
    red::SyntheticBackend backend(*s, *p, s->seed, so);
    red::RuntimeOptions ro;
    ro.realtime = std::getenv("RED_REALTIME") != nullptr;
    ro.external_frames = external;
    if (const char* sp = std::getenv("RED_SPIN_US"))
      ro.spin = std::chrono::microseconds{std::atoi(sp)};
    Outcomes outcomes;
    const std::size_t before = heap_in_use();
    red::RuntimeReport r;
    std::size_t held = 0;
    {
      red::Runtime rt(*s, *p, red::make_policy(v.policy, o), backend, ro);
      rt.add_observer(&outcomes);
      // External frames: one feeder per sensor at its rate, until the scenario's end.
      std::atomic<bool> feeding{external};
      std::vector<std::thread> feeders;
      for (std::size_t i = 0; external && i < s->sensors.size(); ++i)
        feeders.emplace_back([&rt, &feeding, &s, i, &ro] {
          // With RED_REALTIME=1 the feeders run at the priority of the runtime's own camera,
          // one above the handlers (a real-time camera driver), unless RED_FEEDER_OTHER=1 (an
          // ordinary thread).
          if (ro.realtime && std::getenv("RED_FEEDER_OTHER") == nullptr) {
            sched_param sp{};
            sp.sched_priority = ro.rt_priority + 1;
            pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
          }
          const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
              red::period_of(s->sensors[i].rate_hz));
          auto next = std::chrono::steady_clock::now();
          for (std::uint64_t f = 0; feeding.load(); ++f) {
            next += period;
            std::this_thread::sleep_until(next);
            rt.push_frame(static_cast<int>(i), f);
          }
        });
      r = rt.run();
      feeding.store(false);
      for (std::thread& t : feeders) t.join();
      // What the scheduler and synchronizers hold at the end of the run (jobs, tasks,
      // lanes, queues, graphs), less the run's own measurement vectors.
      const std::size_t measurement = (r.decision_us.capacity() + r.handoff_us.capacity() +
                                       r.lock_wait_us.capacity() + r.frame_release_us.capacity()) *
                                      sizeof(double);
      // Memory freed during the run (e.g. by a feeder thread's frames) can leave less in
      // use than before plus the buffers: then nothing is held beyond them.
      const std::size_t now_in_use = heap_in_use();
      held = now_in_use > before + measurement ? now_in_use - before - measurement : 0;
    }
    std::printf(
        "%-16s %6lld %9.2f %9.2f %9.1f %9.1f %8llu %8llu %9.2f %10.2f %9.1f %8.1f %8.1f %8llu\n",
        v.label, outcomes.jobs,
        outcomes.jobs > 0
            ? 100.0 * static_cast<double>(outcomes.missed) / static_cast<double>(outcomes.jobs)
            : 0.0,
        outcomes.completed > 0 ? outcomes.latency_ms / static_cast<double>(outcomes.completed)
                               : 0.0,
        red::percentile(r.handoff_us, 0.5), red::percentile(r.handoff_us, 0.99),
        static_cast<unsigned long long>(r.stats.round_trips),
        static_cast<unsigned long long>(r.local_decisions), red::percentile(r.decision_us, 0.5),
        red::percentile(r.decision_us, 0.99), static_cast<double>(held) / 1024.0,
        red::percentile(r.frame_release_us, 0.5), red::percentile(r.frame_release_us, 0.99),
        static_cast<unsigned long long>(r.direct_releases));
  }
  std::printf(
      "hand = unit completion -> next unit started on that lane (us); rtrips = synchronizer\n"
      "round trips; local = decisions taken by handlers at unit boundaries (on-demand);\n"
      "dec = scheduling decision time inside the runtime (us); heap = bytes the runtime\n"
      "holds at the end of the run beyond its measurement buffers (mallinfo2); rel = frame\n"
      "pushed -> job released (us, RED_EXTERNAL_FRAMES=1 only); direct = frames released by\n"
      "the pushing thread itself.\n");
  return 0;
}
