#include "red/observe/progress.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <ostream>

namespace red {

ProgressReporter::ProgressReporter(const Clock& clock, std::ostream& out, bool enabled,
                                   ProgressOptions options)
    : clock_(clock),
      out_(out),
      enabled_(enabled),
      options_(options),
      origin_(enabled ? clock.now() : TimePoint{0}),
      next_draw_(origin_ + options.delay) {
  if (options_.check_every == 0) options_.check_every = 1;
}

ProgressReporter::~ProgressReporter() {
  finish();
}

bool ProgressReporter::stderr_is_terminal() noexcept {
  return ::isatty(STDERR_FILENO) == 1;
}

void ProgressReporter::begin_run(std::string label, Duration length) {
  label_ = std::move(label);
  length_ = length;
  sim_now_ = TimePoint{0};
  jobs_ = decided_ = missed_ = 0;
  calls_ = 0;
}

void ProgressReporter::finish() {
  if (!drawn_) return;
  out_ << "\r\x1b[K" << std::flush;  // erase the line: later messages start clean
  drawn_ = false;
}

void ProgressReporter::on_job_end(const JobRecord& job) {
  if (job.finish > sim_now_) sim_now_ = job.finish;
  ++jobs_;
  // Counted as in docs/DESIGN.md, "Metrics": a miss is late or dropped; unfinished jobs are not
  // decided yet.
  if (job.outcome != JobOutcome::Unfinished) ++decided_;
  if (job.outcome != JobOutcome::Met && job.outcome != JobOutcome::Unfinished) ++missed_;
  tick();
}

void ProgressReporter::on_decision(TimePoint now, int /*ready*/, int /*idle_lanes*/,
                                   int /*waiting*/) {
  if (now > sim_now_) sim_now_ = now;
  tick();
}

std::string ProgressReporter::line(TimePoint wall) const {
  std::string s = label_.empty() ? std::string("red") : label_;
  s += fmt::format("  elapsed {:.1f} s  {} {:.1f}", to_s(wall - origin_), options_.time_label,
                   to_s(sim_now_));
  if (length_ > Duration{0})
    s += fmt::format("/{:.1f} s ({:.0f}%)", to_s(length_),
                     100.0 * std::min(1.0, to_s(sim_now_) / to_s(length_)));
  else
    s += " s";
  s += fmt::format(
      "  jobs {}  miss {:.1f}%", jobs_,
      decided_ == 0 ? 0.0 : 100.0 * static_cast<double>(missed_) / static_cast<double>(decided_));
  return s;
}

void ProgressReporter::tick() {
  if (!enabled_) return;
  if (++calls_ < options_.check_every) return;
  calls_ = 0;
  const TimePoint wall = clock_.now();
  if (wall < next_draw_) return;
  next_draw_ = wall + options_.interval;
  out_ << '\r' << line(wall) << "\x1b[K" << std::flush;
  drawn_ = true;
  ++draws_;
}

}  // namespace red
