// An output directory's files marked as one set (report/manifest.hpp, issue 39 item 3): a
// run id per run, a manifest.json written last that lists each file with its size and says
// "complete", and an earlier run's manifest replaced before the new run writes anything.

#include "red/report/manifest.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>

#include "../support/cli.hpp"

namespace red {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::read_text;

fs::path fresh_dir(const std::string& name) {
  const fs::path d =
      fs::temp_directory_path() / ("red-manifest-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(d);
  return d;
}

void write(const fs::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary) << text;
}

TEST(OutputSet, RunIdsAreSixteenHexDigitsAndDiffer) {
  const std::string a = new_run_id(), b = new_run_id();
  EXPECT_TRUE(std::regex_match(a, std::regex("[0-9a-f]{16}"))) << a;
  EXPECT_TRUE(std::regex_match(b, std::regex("[0-9a-f]{16}"))) << b;
  EXPECT_NE(a, b);
}

TEST(OutputSet, BeginReplacesTheOldManifestBeforeAnythingIsWritten) {
  const fs::path d = fresh_dir("begin");
  fs::create_directories(d);
  write(d / "summary.json", "{\"old\": true}\n");
  write(d / "manifest.json", R"({"run_id": "old", "complete": true, "files": []})");
  auto set = OutputSet::begin(d.string(), "compare");
  ASSERT_TRUE(set.has_value());
  const json m = json::parse(read_text(d / "manifest.json"));
  EXPECT_EQ(m.at("run_id"), set->run_id());
  EXPECT_EQ(m.at("command"), "compare");
  EXPECT_FALSE(m.at("complete").get<bool>());  // the old files are no complete set now
  EXPECT_TRUE(m.at("files").empty());
  fs::remove_all(d);
}

TEST(OutputSet, FinishListsEachFileWithItsSizeAndSaysComplete) {
  const fs::path d = fresh_dir("finish");
  auto set = OutputSet::begin(d.string(), "simulate");
  ASSERT_TRUE(set.has_value());
  fs::create_directories(d / "plots");
  write(d / "summary.json", "12345");
  write(d / "plots" / "a.svg", "<svg/>");
  set->add("summary.json");
  set->add("plots/a.svg");
  set->add("summary.json");  // listed once
  ASSERT_FALSE(set->finish().has_value());
  const json m = json::parse(read_text(d / "manifest.json"));
  EXPECT_EQ(m.at("schema"), 1);
  EXPECT_EQ(m.at("run_id"), set->run_id());
  EXPECT_TRUE(std::regex_match(m.at("started").get<std::string>(),
                               std::regex(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ)")));
  EXPECT_TRUE(m.at("complete").get<bool>());
  EXPECT_TRUE(m.at("stopped_by").is_null());
  ASSERT_EQ(m.at("files").size(), 2u);
  EXPECT_EQ(m.at("files")[0].at("path"), "summary.json");
  EXPECT_EQ(m.at("files")[0].at("bytes"), 5);
  EXPECT_EQ(m.at("files")[1].at("path"), "plots/a.svg");
  EXPECT_EQ(m.at("files")[1].at("bytes"), 6);
  EXPECT_TRUE(m.at("errors").empty());
  EXPECT_FALSE(fs::exists(d / "manifest.json.partial"));
  fs::remove_all(d);
}

TEST(OutputSet, AFailedOrMissingFileMakesTheSetIncomplete) {
  const fs::path d = fresh_dir("failed");
  {
    auto set = OutputSet::begin(d.string(), "run");
    ASSERT_TRUE(set.has_value());
    write(d / "summary.json", "{}");
    set->add("summary.json");
    set->fail(
        Error{(d / "units.csv.partial").string(), 0, "write failed: No space left on device"});
    ASSERT_FALSE(set->finish().has_value());
    const json m = json::parse(read_text(d / "manifest.json"));
    EXPECT_FALSE(m.at("complete").get<bool>());
    ASSERT_EQ(m.at("errors").size(), 1u);
    EXPECT_NE(m.at("errors")[0].get<std::string>().find("No space left on device"),
              std::string::npos);
    EXPECT_EQ(m.at("files").size(), 1u);
  }
  {
    // A file added but gone by the end is left out, and the set is not complete.
    auto set = OutputSet::begin(d.string(), "run");
    ASSERT_TRUE(set.has_value());
    set->add("gone.csv");
    set->stopped("SIGINT");
    ASSERT_FALSE(set->finish().has_value());
    const json m = json::parse(read_text(d / "manifest.json"));
    EXPECT_FALSE(m.at("complete").get<bool>());
    EXPECT_TRUE(m.at("files").empty());
    EXPECT_EQ(m.at("stopped_by"), "SIGINT");
  }
  fs::remove_all(d);
}

}  // namespace
}  // namespace red
