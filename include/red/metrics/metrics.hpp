#pragma once
/// \file
/// Metrics (docs/DESIGN.md, "Metrics"), collected by an observer of the scheduler: per-job records,
/// per-unit records, and the summary of one policy's run. The warm-up window is excluded.

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "red/metrics/distribution.hpp"
#include "red/metrics/tally.hpp"
#include "red/scenario/scenario.hpp"
#include "red/sched/observer.hpp"
#include "red/sched/online_costs.hpp"

namespace red {

/// One row of jobs.csv.
struct JobRow {
  int operation = -1;
  std::uint64_t seq = 0;
  JobId id = 0;
  TimePoint release{0};
  TimePoint finish{0};
  TimePoint deadline{0};
  JobOutcome outcome = JobOutcome::Unfinished;
  double qoe = 0.0;
  Duration frame_age{0};
  std::string reason;
  /// Why it did not meet its deadline (metrics/why.hpp); empty when it met it or before
  /// annotate_causes().
  std::string cause;
  /// The lane time behind `cause` by share ("own 12.300; held 4.000"); empty for a rule.
  std::string cause_ms;
};

/// One row of units.csv: a unit execution (merged or batched).
struct UnitRow {
  std::uint64_t dispatch = 0;
  int lane = 0;
  TimePoint decided{0};
  TimePoint start{0};
  TimePoint end{0};
  UnitKind kind = UnitKind::Plain;
  int head = -1;
  int batch = 1;
  int members = 1;
  bool round_trip = true;
  UnitStatus status = UnitStatus::Completed;
  std::string jobs;  ///< "op#seq:node ..." of every member
  /// What the scheduler expected the run to cost when it decided it (Dispatch::expected);
  /// 0 when unknown.
  Duration expected{0};
};

/// Latency figures in milliseconds.
struct LatencySummary {
  double mean = 0, p50 = 0, p90 = 0, p99 = 0, max = 0;
};

/// The summary of one policy's run (one entry of summary.json).
struct PolicyMetrics {
  std::string name;
  std::int64_t jobs = 0;  ///< released after warm-up
  std::int64_t completed = 0, met = 0, missed = 0, dropped = 0, skipped = 0, failed = 0,
               unfinished = 0;
  double miss_rate = 0, drop_rate = 0, qoe = 0;
  double on_time = 0;  ///< met / jobs: the share of released jobs that met their deadline
  /// Dropped, skipped and failed jobs by reason ("deadline passed", "hopeless", "rejected at
  /// release", "max_inflight", or the failure).
  std::map<std::string, std::int64_t> drop_reasons;
  /// Share of the busy lane time spent on jobs that were then dropped or failed (docs/DESIGN.md,
  /// "Overload").
  double wasted_lane_fraction = 0;
  LatencySummary latency;
  std::int64_t encoder_runs = 0, encoder_runs_saved = 0;
  std::int64_t sync_round_trips = 0, dispatches = 0, merge_waits = 0;
  std::map<int, std::int64_t> batch_sizes;  ///< batch size -> dispatches
  std::vector<double> lane_utilization;
  std::map<std::string, double> throughput_hz;  ///< outputs per second, per head
  double frame_age_mean_ms = 0, frame_age_p99_ms = 0;
  double measured_s = 0;  ///< length of the measured window (after warm-up)
  /// Ratios vs the baseline (docs/CLI.md): miss_rate, latency_mean, qoe; absent without baseline.
  std::optional<double> ratio_miss, ratio_latency, ratio_qoe;
  /// Runtime only: measured scheduler decision time (μs): p50, p99.
  std::optional<double> decision_p50_us, decision_p99_us;
  /// Failed jobs by reason ("timeout", "out of memory: ...", an exception's message).
  std::map<std::string, std::int64_t> failure_reasons;
  /// Runtime only: the process's peak resident set while the run was sampled (MB).
  std::optional<double> peak_rss_mb;
  /// Runtime only: the sensors' frames in the measured window, offered and released, and
  /// how late they were released (release - nominal capture time). The simulator releases
  /// every frame at its capture time.
  struct Releases {
    std::int64_t offered = 0, released = 0;
    std::int64_t behind = 0;  ///< released later than one period of their sensor
    double late_p50_ms = 0, late_p99_ms = 0, late_max_ms = 0;
  };
  std::optional<Releases> releases;
  /// Set when the latency and frame-age percentiles are estimates (more completed jobs than
  /// BoundedDistribution keeps exactly): the relative error of each percentile.
  std::optional<double> percentile_error;
  std::int64_t percentile_exact_up_to = 0;  ///< values kept exactly (with percentile_error)
  /// Online cost estimates (docs/DESIGN.md, "Online costs"): on in this run, the plan's
  /// changes, and the profile's costs against the run's per unit and batch size.
  bool online_costs = false;
  int plan_changes = 0;
  std::vector<UnitCostFigures> costs;
};

/// Nearest-rank percentile (p in [0, 1]) of values already sorted ascending; 0 when empty.
double percentile_sorted(const std::vector<double>& sorted, double p);

/// Nearest-rank percentile of unsorted values (sorts a copy).
double percentile(std::vector<double> values, double p);

/// QoE of one completed job (docs/DESIGN.md, "Metrics", the paper's Eq. 1): 1 / (1 + e^λ · max(0, R
/// − D)), R and D in seconds.
double qoe_score(Duration response, Duration deadline, double lambda);

/// Where a collector hands each job and unit row as it is made (a streamed jobs.csv and
/// units.csv, report/stream.hpp). Called on the thread that reports the run's events.
class RowSink {
 public:
  virtual ~RowSink() = default;
  /// A job that ended after the warm-up.
  virtual void on_job_row(const JobRow& row) = 0;
  /// A unit execution that started after the warm-up.
  virtual void on_unit_row(const UnitRow& row) = 0;
  /// Called now and then with no new row (RowQueue's writer, at each look), so that a sink
  /// that buffers can write out rows that have waited long enough. Does nothing by default.
  virtual void poll() {}
};

/// Collects job and unit records. Attach before the run; summarize after it. The summary
/// needs only counters and two bounded distributions; the rows themselves are kept (for
/// jobs(), units()) unless set_keep_rows(false), and handed to a RowSink if one is set, so
/// a run of any length can keep bounded state.
class MetricsCollector final : public Observer {
 public:
  /// `keep_units`: make unit rows (units.csv) at all.
  MetricsCollector(const Scenario& s, double qoe_lambda, bool keep_units = true);

  /// Hands every row to `sink` as it is made (null: none). Set before the run.
  void set_sink(RowSink* sink) noexcept { sink_ = sink; }
  /// Keeps the rows in memory (default) or not. With them (the simulator) every response
  /// time is kept too, so percentiles are exact at any length; without them jobs() and
  /// units() are empty and the summary is the same up to BoundedDistribution::kDefaultCap
  /// completed jobs, estimated past it. Call before the run.
  void set_keep_rows(bool keep);
  /// Records held (rows, distribution values and buckets, jobs in flight, reasons): what
  /// its memory grows with. Bounded over a run's length without kept rows.
  [[nodiscard]] std::size_t kept() const noexcept;

  void on_job_end(const JobRecord& j) override;
  void on_unit_start(const Dispatch& d) override;
  void on_unit_end(const Dispatch& d, TimePoint end, UnitStatus s) override;
  void on_merge_wait(int sensor, TimePoint now, TimePoint until) override;

  /// Summary of the run that ended at `end`.
  [[nodiscard]] PolicyMetrics summarize(const std::string& name, TimePoint end) const;
  [[nodiscard]] const std::vector<JobRow>& jobs() const noexcept { return jobs_; }
  [[nodiscard]] const std::vector<UnitRow>& units() const noexcept { return units_; }
  /// Hands over the job rows (leaves none): after summarize(), instead of copying them.
  [[nodiscard]] std::vector<JobRow> take_jobs() noexcept { return std::move(jobs_); }
  /// Hands over the unit rows (leaves none), as take_jobs().
  [[nodiscard]] std::vector<UnitRow> take_units() noexcept { return std::move(units_); }

 private:
  void count(const JobRow& j);  // adds an ended job to the summary's counters
  const Scenario& scenario_;
  double lambda_;
  bool keep_units_;
  bool keep_rows_ = true;
  RowSink* sink_ = nullptr;
  std::vector<JobRow> jobs_;
  std::vector<UnitRow> units_;
  std::vector<Duration> busy_;  // per lane, after warm-up
  std::int64_t encoder_runs_ = 0, encoder_saved_ = 0, round_trips_ = 0, dispatches_ = 0,
               merge_waits_ = 0;
  std::map<int, std::int64_t> batches_;
  std::vector<std::int64_t> head_outputs_;
  // Lane time of the jobs with units still to account for (shared units split): a job's
  // entry goes once it has ended and none of its units is running, so the map holds about
  // the jobs in flight, however long the run.
  struct Spent {
    Duration time{0};
    int running = 0;      // its units started and not ended
    bool ended = false;   // on_job_end seen
    bool wasted = false;  // ended dropped, skipped or failed after the warm-up
  };
  std::unordered_map<JobId, Spent> spent_;
  Duration wasted_{0};  // lane time of the jobs dropped, skipped or failed after the warm-up
  // The jobs ended after the warm-up, in the order they ended: by outcome (what counts as a
  // miss, how QoE is averaged), and the reasons of those without result (drop_reasons,
  // failure_reasons; its other figures are filled by summarize()).
  OutcomeTally tally_;
  PolicyMetrics counts_;
  BoundedDistribution latency_{BoundedDistribution::kUnbounded};    // response times (ms)
  BoundedDistribution frame_age_{BoundedDistribution::kUnbounded};  // their frame ages (ms)
};

/// Fills ratio_* of every entry against the entry named `baseline` (if present).
void apply_ratios(std::vector<PolicyMetrics>& all, const std::string& baseline);

}  // namespace red
