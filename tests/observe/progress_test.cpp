// The progress line: quiet unless enabled and until the delay has passed, rate-limited,
// erased at the end. Wall time comes from a fake Clock: no sleeps, no timing assertions.

#include "red/observe/progress.hpp"

#include <gtest/gtest.h>

#include <sstream>
#include <string>

namespace red {
namespace {

class FakeClock final : public Clock {
 public:
  [[nodiscard]] TimePoint now() const noexcept override { return now_; }
  void set(Duration t) { now_ = t; }

 private:
  TimePoint now_{0};
};

using std::chrono::milliseconds;
using std::chrono::seconds;

JobRecord job(JobOutcome o, Duration finish) {
  JobRecord j;
  j.outcome = o;
  j.finish = finish;
  return j;
}

ProgressOptions every_call() {
  ProgressOptions o;
  o.check_every = 1;  // read the (fake) clock on every callback
  return o;
}

TEST(Progress, QuietWhenNotATerminal) {
  FakeClock clock;
  std::ostringstream out;
  ProgressReporter p(clock, out, /*enabled=*/false, every_call());
  p.begin_run("red", seconds{10});
  clock.set(seconds{30});
  for (int i = 0; i < 1000; ++i) p.on_decision(milliseconds{i}, 1, 0, 0);
  p.finish();
  EXPECT_EQ(out.str(), "");
  EXPECT_EQ(p.draws(), 0u);
}

TEST(Progress, QuietForShortRuns) {
  FakeClock clock;
  std::ostringstream out;
  ProgressReporter p(clock, out, true, every_call());
  p.begin_run("red", seconds{10});
  clock.set(milliseconds{1500});  // below the 2 s delay
  for (int i = 0; i < 100; ++i) p.on_decision(milliseconds{i}, 1, 0, 0);
  p.finish();
  EXPECT_EQ(out.str(), "");
}

TEST(Progress, OneUpdatingLineWithTimesJobsAndMissRate) {
  FakeClock clock;
  std::ostringstream out;
  ProgressReporter p(clock, out, true, every_call());
  p.begin_run("edf [3/6]", seconds{10});
  p.on_job_end(job(JobOutcome::Met, seconds{1}));
  p.on_job_end(job(JobOutcome::Missed, seconds{2}));
  p.on_job_end(job(JobOutcome::Dropped, seconds{3}));
  p.on_job_end(job(JobOutcome::Met, seconds{3}));
  clock.set(milliseconds{3200});
  p.on_decision(seconds{4}, 2, 0, 0);
  const std::string s = out.str();
  ASSERT_FALSE(s.empty());
  EXPECT_EQ(s.front(), '\r');
  EXPECT_EQ(s.find('\n'), std::string::npos);  // one line, redrawn in place
  EXPECT_NE(s.find("edf [3/6]"), std::string::npos) << s;
  EXPECT_NE(s.find("elapsed 3.2 s"), std::string::npos) << s;
  EXPECT_NE(s.find("sim 4.0/10.0 s (40%)"), std::string::npos) << s;
  EXPECT_NE(s.find("jobs 4"), std::string::npos) << s;
  EXPECT_NE(s.find("miss 50.0%"), std::string::npos) << s;
  EXPECT_EQ(p.draws(), 1u);
}

TEST(Progress, RateLimited) {
  FakeClock clock;
  std::ostringstream out;
  ProgressReporter p(clock, out, true, every_call());
  p.begin_run("red", seconds{10});
  clock.set(seconds{3});
  for (int i = 0; i < 50; ++i) p.on_decision(milliseconds{i}, 1, 0, 0);
  EXPECT_EQ(p.draws(), 1u);
  clock.set(seconds{3} + milliseconds{100});
  for (int i = 0; i < 50; ++i) p.on_decision(milliseconds{i}, 1, 0, 0);
  EXPECT_EQ(p.draws(), 1u);  // within the 250 ms interval
  clock.set(seconds{3} + milliseconds{300});
  p.on_decision(seconds{1}, 1, 0, 0);
  EXPECT_EQ(p.draws(), 2u);
}

TEST(Progress, ReadsTheClockOncePerBatchOfCallbacks) {
  FakeClock clock;
  std::ostringstream out;
  ProgressOptions o;
  o.check_every = 100;
  ProgressReporter p(clock, out, true, o);
  p.begin_run("red", seconds{10});
  clock.set(seconds{5});
  for (int i = 0; i < 99; ++i) p.on_decision(milliseconds{i}, 1, 0, 0);
  EXPECT_EQ(p.draws(), 0u);
  p.on_decision(milliseconds{100}, 1, 0, 0);
  EXPECT_EQ(p.draws(), 1u);
}

TEST(Progress, FinishErasesTheLineOnlyWhenOneWasDrawn) {
  FakeClock clock;
  std::ostringstream out;
  ProgressReporter p(clock, out, true, every_call());
  p.begin_run("red", seconds{10});
  p.finish();
  EXPECT_EQ(out.str(), "");
  clock.set(seconds{3});
  p.on_decision(seconds{1}, 1, 0, 0);
  p.finish();
  const std::string s = out.str();
  EXPECT_EQ(s.substr(s.size() - 4), "\r\x1b[K");
  p.finish();  // idempotent
  EXPECT_EQ(out.str(), s);
}

TEST(Progress, ElapsedTimeSpansRunsCountsDoNot) {
  FakeClock clock;
  std::ostringstream out;
  ProgressReporter p(clock, out, true, every_call());
  p.begin_run("a", seconds{10});
  p.on_job_end(job(JobOutcome::Missed, seconds{9}));
  p.begin_run("b", seconds{0});
  p.on_job_end(job(JobOutcome::Met, seconds{1}));
  const std::string line = p.line(seconds{7});
  EXPECT_NE(line.find("elapsed 7.0 s"), std::string::npos) << line;
  EXPECT_NE(line.find("jobs 1"), std::string::npos) << line;
  EXPECT_NE(line.find("miss 0.0%"), std::string::npos) << line;
  EXPECT_NE(line.find("sim 1.0 s"), std::string::npos) << line;  // no length: no percentage
}

}  // namespace
}  // namespace red
