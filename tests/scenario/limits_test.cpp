// Hostile input (issue 39): every class gets a clear error naming the file (and the line where
// there is one), never a crash, an overflow or an unbounded allocation.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "red/core/file.hpp"
#include "red/profile/profile.hpp"
#include "red/scenario/loader.hpp"

namespace red {
namespace {

// A one-camera scenario; `deadline` is the operation's deadline_ms value, `extra` more
// top-level YAML.
std::string scenario(const std::string& deadline = "60", const std::string& extra = "",
                     const std::string& name = "limits") {
  return "name: " + name +
         "\nduration_s: 2\nseed: 1\ndevice: {lanes: 1}\n"
         "model: {builtin: mimonet, heads: [lane, steer], input: [3, 192, 384]}\n"
         "sensors:\n  camera: {rate_hz: 20}\n"
         "operations:\n  - name: drive\n    trigger: camera\n    deadline_ms: " +
         deadline +
         "\n    nodes:\n      L: {head: lane, sensor: camera}\n"
         "      C: {head: steer, sensor: camera}\n    edges: [[L, C]]\n" +
         extra;
}

void expect_error(const std::string& yaml, int line, const std::string& fragment) {
  SCOPED_TRACE(yaml.substr(0, 200));
  const Expected<Scenario> s = parse_scenario(yaml, "s.yaml");
  ASSERT_FALSE(s.has_value()) << "accepted";
  EXPECT_EQ(s.error().file, "s.yaml");
  if (line >= 0) {
    EXPECT_EQ(s.error().line, line) << s.error().to_string();
  }
  EXPECT_NE(s.error().message.find(fragment), std::string::npos) << s.error().to_string();
}

TEST(InputLimits, TheBaseScenarioLoads) {
  ASSERT_TRUE(parse_scenario(scenario(), "s.yaml").has_value());
}

TEST(InputLimits, NamesMustBeUtf8) {
  // A name that is not UTF-8 once passed validate and aborted every --out writer.
  expect_error(scenario("60", "",
                        "ch\xff"
                        "ain"),
               1, "byte 0xff is not valid UTF-8");
  expect_error(scenario("60", "", "a\xc0\xaf"), 1, "not valid UTF-8");      // overlong '/'
  expect_error(scenario("60", "", "a\xed\xa0\x80"), 1, "not valid UTF-8");  // a surrogate
  EXPECT_TRUE(parse_scenario(scenario("60", "", "caf\xc3\xa9 \xe2\x9c\x93"), "s.yaml"))
      << "UTF-8 names are fine";
}

TEST(InputLimits, ASecondYamlDocumentIsAnError) {
  expect_error(scenario() + "---\nname: other\n", 16, "a second YAML document");
  EXPECT_TRUE(parse_scenario("---\n" + scenario() + "...\n# done\n", "s.yaml"))
      << "one document with its markers";
  EXPECT_EQ(second_yaml_document_line("a: 1\n...\nb: 2\n"), 3);
  EXPECT_EQ(second_yaml_document_line("%YAML 1.2\n---\na: 1\n"), 0);
  EXPECT_EQ(second_yaml_document_line("---\n---\n"), 2);
  EXPECT_EQ(second_yaml_document_line("a: |\n  ---\n"), 0) << "indented: inside a scalar";
  // yaml-cpp's LoadAll never returned on this (found by fuzzing): a clear error instead.
  EXPECT_FALSE(parse_scenario(",`eoutput\n", "s.yaml").has_value());
}

TEST(InputLimits, DeadlinesThatOverflowOrVanishAreRefused) {
  // critical_path_x 1e308 once gave a deadline of -9.2e12 ms and dropped every job.
  expect_error(scenario("{critical_path_x: 1e308}"), 11, "must lie in [0.001, 1e+06]");
  expect_error(scenario("{critical_path_x: 1e-9}"), 11, "must lie in");
  expect_error(scenario("1e-9"), 11, "too small");
  expect_error(scenario("1e13"), 11, "too large");
  expect_error(scenario("60",
                        "events:\n  - {at_s: 1, set_deadline: {operation: drive, "
                        "deadline_ms: {critical_path_x: 1e308}}}\n"),
               -1, "must lie in");
  Scenario s = *parse_scenario(scenario(), "s.yaml");
  const auto tiny = apply_override(s, "deadline_scale", 1e-300);
  ASSERT_TRUE(tiny.has_value()) << "deadline_scale=1e-300 accepted";
  EXPECT_NE(tiny->message.find("would leave its range"), std::string::npos) << tiny->message;
  Scenario x = *parse_scenario(scenario("{critical_path_x: 1.5}"), "s.yaml");
  EXPECT_TRUE(apply_override(x, "deadline_scale", 1e300).has_value());
  EXPECT_FALSE(apply_override(x, "deadline_scale", 2).has_value()) << "an ordinary scale";
}

TEST(InputLimits, WorkloadsTooLargeForAMachineAreRefusedAtLoad) {
  expect_error(scenario("60", "").replace(scenario().find("lanes: 1"), 8, "lanes: 2147483647"), 4,
               "");
  {
    std::string y = scenario();
    y.replace(y.find("duration_s: 2"), 13, "duration_s: 1e9");
    expect_error(y, 0, "jobs in");  // 20 Hz for 1e9 s
  }
  {
    std::string y = scenario();
    y.replace(y.find("    trigger: camera\n"), 20, "    release: {count: 100000000}\n");
    expect_error(y, -1, "");
  }
  Scenario s = *parse_scenario(scenario(), "s.yaml");
  const auto long_run = apply_override(s, "duration_s", 1e9);
  ASSERT_TRUE(long_run.has_value());
  EXPECT_NE(long_run->message.find("jobs in"), std::string::npos) << long_run->message;
  EXPECT_TRUE(apply_override(s, "lanes", 1e6).has_value());
  EXPECT_FALSE(apply_override(s, "lanes", 4).has_value());
}

TEST(InputLimits, InputFilesAreReadUpToALimit) {
  const auto zero = read_file("/dev/zero");  // endless: 64 MiB read, then an error
  ASSERT_FALSE(zero.has_value());
  EXPECT_NE(zero.error().message.find("larger than the 64 MiB"), std::string::npos)
      << zero.error().message;
  const std::filesystem::path big =
      std::filesystem::temp_directory_path() / "red-limits-test-big.yaml";
  {
    std::ofstream f(big);
    f << std::string(5000, '#');
  }
  EXPECT_FALSE(read_file(big.string(), 4096).has_value());
  EXPECT_TRUE(read_file(big.string(), 8192).has_value());
  std::filesystem::remove(big);
}

TEST(InputLimits, DeeplyNestedJsonIsRefusedBeforeParsing) {
  // 100,000 levels once overflowed the parser's stack (SIGSEGV).
  const std::string deep =
      "{\"schema\": 1, \"units\": " + std::string(100000, '[') + std::string(100000, ']') + "}";
  const auto p = parse_profile(deep, "deep.json");
  ASSERT_FALSE(p.has_value());
  EXPECT_EQ(p.error().line, 1);
  EXPECT_NE(p.error().message.find("nested deeper than 64"), std::string::npos)
      << p.error().message;
  // Brackets inside strings do not count.
  EXPECT_FALSE(check_json_depth("{\"a\": \"" + std::string(1000, '[') + "\"}", "f").has_value());
  EXPECT_TRUE(check_json_depth("\n\n" + std::string(65, '['), "f").has_value());
  EXPECT_EQ(check_json_depth("\n\n" + std::string(65, '['), "f")->line, 3);
}

TEST(InputLimits, ADuplicateKeyInAProfileIsAnError) {
  const std::string text =
      "{\"schema\": 1,\n \"units\": {\"encoder\": [{\"batch\": 1, \"min_us\": 1, \"mean_us\": 1, "
      "\"p50_us\": 1, \"p95_us\": 1, \"p99_us\": 1, \"max_us\": 1}]},\n \"schema\": 1}";
  const auto p = parse_profile(text, "dup.json");
  ASSERT_FALSE(p.has_value()) << "the second \"schema\" replaced the first silently";
  EXPECT_EQ(p.error().line, 3);
  EXPECT_NE(p.error().message.find("duplicate key \"schema\""), std::string::npos)
      << p.error().message;
}

TEST(InputLimits, ErrorMessagesShowAValueCutToALine) {
  const std::string huge = "[" + std::string(200000, '1') + "]";
  const auto p = parse_profile(
      "{\"schema\": 1, \"units\": {\"encoder\": [{\"batch\": " + huge + "}]}}", "big.json");
  ASSERT_FALSE(p.has_value());
  EXPECT_LT(p.error().message.size(), 300U) << "the message printed the whole value";
}

}  // namespace
}  // namespace red
