// A real run streams its rows (issue 10 item 3): the runtime with the synthetic backend, in
// real time, writes jobs.csv and units.csv as jobs end, byte for byte what the in-memory
// writers give for the same run, and its summary needs none of the rows. Wall-clock: its
// own executable, labelled `integration`.

#include <gtest/gtest.h>

#include <unistd.h>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "../support/cli.hpp"
#include "red/metrics/metrics.hpp"
#include "red/report/report.hpp"
#include "red/report/stream.hpp"
#include "red/runtime/runtime.hpp"
#include "red/runtime/synthetic_backend.hpp"
#include "red/scenario/loader.hpp"

namespace red {
namespace {

namespace fs = std::filesystem;
using test::read_text;

constexpr const char* kScenario = R"(
name: stream
duration_s: 1.2
warmup_s: 0.2
seed: 3
device: {lanes: 2}
model: {builtin: mimonet, heads: [lane, seg, steer, det], input: [3, 192, 384]}
sensors:
  camera: {rate_hz: 40}
operations:
  - name: cruise
    trigger: camera
    deadline_ms: 60
    nodes:
      L: {head: lane, sensor: camera}
      S: {head: seg, sensor: camera}
      C: {head: steer, sensor: camera}
    edges: [[L, S], [S, C]]
  - name: detect
    rate_hz: 25
    deadline_ms: 50
    nodes:
      O: {head: det, sensor: camera}
)";

fs::path fresh_dir(const std::string& name) {
  const fs::path d =
      fs::temp_directory_path() / ("red-stream-run-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(d);
  return d;
}

TEST(StreamedRun, RowsEqualTheInMemoryRowsAndTheSummaryNeedsNone) {
  auto s = parse_scenario(kScenario, "stream.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  const Profile p = default_profile();
  SyntheticBackend::Options so;
  so.time_scale = 0.3;
  SyntheticBackend backend(*s, p, 1, so);
  RuntimeOptions ro;
  ro.realtime = false;
  ro.watchdog_x = 0.0;
  Runtime rt(*s, p, make_policy("red"), backend, ro);
  const fs::path dir = fresh_dir("same");
  auto stream = CsvRowStream::open(dir.string(), *s, true);
  ASSERT_TRUE(stream.has_value());
  (*stream)->begin_policy("red");
  MetricsCollector kept(*s, 1.0);  // the rows in memory, as before streaming
  kept.set_sink(stream->get());
  MetricsCollector bounded(*s, 1.0);  // counters and distributions only
  bounded.set_keep_rows(false);
  rt.add_observer(&kept);
  rt.add_observer(&bounded);
  const RuntimeReport report = rt.run();
  ASSERT_FALSE((*stream)->flush().has_value());
  ASSERT_FALSE((*stream)->finish().has_value());

  ASSERT_FALSE(kept.jobs().empty());
  ASSERT_FALSE(kept.units().empty());
  EXPECT_TRUE(bounded.jobs().empty());
  EXPECT_TRUE(bounded.units().empty());
  EXPECT_EQ(read_text(dir / "jobs.csv"), jobs_csv(*s, {{"red", &kept.jobs()}}));
  EXPECT_EQ(read_text(dir / "units.csv"), units_csv(*s, {{"red", &kept.units()}}));
  EXPECT_EQ((*stream)->job_rows(), static_cast<std::int64_t>(kept.jobs().size()));
  SummaryHeader h;
  h.scenario = s->name;
  EXPECT_EQ(summary_json(h, {kept.summarize("red", report.end)}),
            summary_json(h, {bounded.summarize("red", report.end)}));
  fs::remove_all(dir);
}

TEST(StreamedRun, RedRunWritesItsReportFromTheStreamedRows) {
  const fs::path dir = fresh_dir("cli");
  const std::string cmd = "RED_GNUPLOT=none " + std::string(RED_CLI) + " run " +
                          test::quote(std::string(RED_TEST_DATA) + "/cli/signal.yaml") +
                          " --backend synthetic --policy red --no-realtime --set duration_s=2" +
                          " --out " + test::quote(dir.string()) + " > " +
                          test::quote((dir.string() + ".log")) + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << read_text(dir.string() + ".log");
  const auto summary = nlohmann::json::parse(read_text(dir / "summary.json"));
  const auto& pol = summary["policies"][0];
  // One row per job after the warm-up, and the summary's percentiles exact (a short run).
  std::istringstream jobs(read_text(dir / "jobs.csv"));
  std::int64_t rows = -1;
  for (std::string line; std::getline(jobs, line);) ++rows;
  EXPECT_EQ(rows, pol["jobs"].get<std::int64_t>());
  EXPECT_GT(rows, 0);
  EXPECT_FALSE(pol.contains("percentiles"));
  EXPECT_TRUE(pol.contains("phases"));
  EXPECT_FALSE(read_text(dir / "units.csv").empty());
  bool timeline = false;
  for (const auto& e : fs::directory_iterator(dir / "plots"))
    timeline = timeline || e.path().filename().string().rfind("timeline", 0) == 0;
  EXPECT_TRUE(timeline) << "the timeline is drawn from the rows";
  fs::remove_all(dir);
  fs::remove(dir.string() + ".log");
}

}  // namespace
}  // namespace red
