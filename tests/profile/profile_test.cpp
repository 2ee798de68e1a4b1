// Profiles (docs/DESIGN.md, "Profiles"): the built-in default, JSON round trip, validation,
// quantiles, coverage.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "red/profile/profile.hpp"
#include "red/scenario/loader.hpp"

namespace red {
namespace {

using std::chrono::microseconds;
using std::chrono::milliseconds;

bool same(const LatencyStats& a, const LatencyStats& b) {
  return a.min == b.min && a.mean == b.mean && a.p50 == b.p50 && a.p95 == b.p95 && a.p99 == b.p99 &&
         a.max == b.max && a.samples == b.samples;
}

void expect_same(const Profile& a, const Profile& b) {
  EXPECT_EQ(a.source, b.source);
  EXPECT_EQ(a.device, b.device);
  EXPECT_EQ(a.model, b.model);
  EXPECT_EQ(a.sync_round_trip, b.sync_round_trip);
  EXPECT_DOUBLE_EQ(a.profile_wall_s, b.profile_wall_s);
  ASSERT_EQ(a.units.size(), b.units.size());
  for (const auto& [name, unit] : a.units) {
    const UnitProfile* other = b.find(name);
    ASSERT_NE(other, nullptr) << name;
    ASSERT_EQ(unit.max_batch(), other->max_batch()) << name;
    for (int k = 1; k <= unit.max_batch(); ++k)
      EXPECT_TRUE(same(unit.at(k), other->at(k))) << name << " batch " << k;
  }
  ASSERT_EQ(a.shared_memory.has_value(), b.shared_memory.has_value());
  if (a.shared_memory) {
    EXPECT_EQ(a.shared_memory->parameter_bytes, b.shared_memory->parameter_bytes);
    EXPECT_EQ(a.shared_memory->peak_activation_bytes, b.shared_memory->peak_activation_bytes);
    EXPECT_EQ(a.shared_memory->resident_bytes, b.shared_memory->resident_bytes);
  }
  EXPECT_EQ(a.separate_memory.has_value(), b.separate_memory.has_value());
}

TEST(Profile, DefaultProfileFigures) {
  const Profile p = default_profile();
  EXPECT_EQ(p.source, "builtin-default");
  EXPECT_EQ(p.device, "reference CPU (illustrative)");
  EXPECT_EQ(p.model, "mimonet [3,192,384]");
  EXPECT_EQ(p.sync_round_trip, microseconds{50});
  // encoder + 4 heads, each with coarse and separate variants.
  EXPECT_EQ(p.units.size(), 13U);
  const LatencyStats& e1 = p.find("encoder")->at(1);
  EXPECT_EQ(e1.mean, milliseconds{12});
  EXPECT_EQ(e1.p50, milliseconds{12});
  EXPECT_EQ(e1.p99, milliseconds{14});
  EXPECT_EQ(e1.min, microseconds{10800});
  EXPECT_EQ(e1.p95, microseconds{13200});
  EXPECT_EQ(e1.max, microseconds{16100});
  EXPECT_EQ(e1.samples, 0);
  const LatencyStats& steer = p.find("head/steer")->at(1);
  EXPECT_EQ(steer.mean, microseconds{600});
  EXPECT_EQ(steer.p99, microseconds{750});
  // Batch 3 costs 1 + 0.55 * 2 = 2.1 times one run.
  const LatencyStats& e3 = p.find("encoder")->at(3);
  EXPECT_EQ(e3.mean, microseconds{25200});
  EXPECT_EQ(e3.p99, microseconds{29400});
  EXPECT_EQ(p.find("encoder")->max_batch(), 4);
  // Coarse = encoder + head, statistic by statistic; separate = coarse.
  const LatencyStats& c2 = p.find("coarse/det")->at(2);
  EXPECT_EQ(c2.mean, p.find("encoder")->at(2).mean + p.find("head/det")->at(2).mean);
  EXPECT_EQ(c2.max, p.find("encoder")->at(2).max + p.find("head/det")->at(2).max);
  EXPECT_TRUE(same(p.find("separate/lane")->at(4), p.find("coarse/lane")->at(4)));
  // The encoder dominates every head (docs/DESIGN.md, "Built-in model").
  for (const char* h : {"head/lane", "head/seg", "head/steer", "head/det"})
    EXPECT_LT(p.find(h)->at(1).p99, e1.mean) << h;
  EXPECT_EQ(p.find("head/nope"), nullptr);
}

TEST(Profile, DefaultRoundTripsExactly) {
  const Profile p = default_profile();
  const std::string text = profile_to_json(p);
  const Expected<Profile> q = parse_profile(text, "default.json");
  ASSERT_TRUE(q.has_value()) << q.error().to_string();
  expect_same(p, *q);
  EXPECT_EQ(profile_to_json(*q), text);
}

TEST(Profile, MeasuredFieldsRoundTrip) {
  Profile p = default_profile();
  p.source = "measured";
  p.device = "cpu (2 threads)";
  p.profile_wall_s = 9.1;
  p.sync_round_trip = Duration{12'345};
  p.units["encoder"].by_batch[0].samples = 50;
  p.units["encoder"].by_batch[0].p95 = Duration{13'200'001};  // odd nanoseconds survive
  p.shared_memory = MemoryStats{1'000'000, 2'000'000, 300'000'000};
  p.separate_memory = MemoryStats{4'000'000, 5'000'000, 600'000'000};
  const Expected<Profile> q = parse_profile(profile_to_json(p), "m.json");
  ASSERT_TRUE(q.has_value()) << q.error().to_string();
  expect_same(p, *q);
  EXPECT_EQ(q->separate_memory->resident_bytes, 600'000'000);
}

TEST(Profile, LoadFromFileAndMissingFile) {
  const auto path = std::filesystem::temp_directory_path() / "red_profile_test.json";
  {
    std::ofstream out(path);
    out << profile_to_json(default_profile());
  }
  const Expected<Profile> p = load_profile(path.string());
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  EXPECT_EQ(p->source, "builtin-default");
  std::filesystem::remove(path);
  const Expected<Profile> missing = load_profile(path.string());
  ASSERT_FALSE(missing.has_value());
  EXPECT_EQ(missing.error().file, path.string());
  EXPECT_NE(missing.error().message.find("cannot open"), std::string::npos);
}

TEST(Profile, QuantileHitsTheKnotsAndIsMonotone) {
  const LatencyStats s = default_profile().find("encoder")->at(1);
  EXPECT_EQ(s.quantile(0.0), s.min);
  EXPECT_EQ(s.quantile(0.5), s.p50);
  EXPECT_EQ(s.quantile(0.95), s.p95);
  EXPECT_EQ(s.quantile(0.99), s.p99);
  EXPECT_EQ(s.quantile(1.0), s.max);
  EXPECT_EQ(s.quantile(-1.0), s.min);  // clamped
  EXPECT_EQ(s.quantile(2.0), s.max);
  // Halfway between two knots is halfway between their values.
  EXPECT_EQ(s.quantile(0.25), (s.min + s.p50) / 2);
  Duration last = s.quantile(0.0);
  for (int i = 1; i <= 10000; ++i) {
    const Duration d = s.quantile(static_cast<double>(i) / 10000.0);
    EXPECT_LE(last, d) << i;
    last = d;
  }
}

TEST(Profile, EstimateAndClampedBatch) {
  const Profile p = default_profile();
  const UnitProfile& u = *p.find("head/seg");
  const LatencyStats& s = u.at(1);
  EXPECT_EQ(s.estimate(EstimateKind::Mean), s.mean);
  EXPECT_EQ(s.estimate(EstimateKind::P95), s.p95);
  EXPECT_EQ(s.estimate(EstimateKind::P99), s.p99);
  EXPECT_EQ(s.estimate(EstimateKind::Max), s.max);
  EXPECT_EQ(&u.at(0), &u.at(1));
  EXPECT_EQ(&u.at(-3), &u.at(1));
  EXPECT_EQ(&u.at(9), &u.at(4));
}

/// A small valid profile document to break in the tests below.
nlohmann::json small() {
  return nlohmann::json::parse(R"({
  "schema": 1, "source": "measured", "device": "cpu", "model": "m",
  "sync_round_trip_us": 12.5,
  "units": {"encoder": [
    {"batch": 1, "samples": 5, "min_us": 1, "mean_us": 2, "p50_us": 2, "p95_us": 3, "p99_us": 4, "max_us": 5},
    {"batch": 2, "samples": 5, "min_us": 2, "mean_us": 3, "p50_us": 3, "p95_us": 4, "p99_us": 5, "max_us": 6}]}
})");
}

Error error_of(const nlohmann::json& doc) {
  const Expected<Profile> p = parse_profile(doc.dump(), "bad.json");
  EXPECT_FALSE(p.has_value()) << doc.dump();
  return p ? Error{} : p.error();
}

bool mentions(const Error& e, const std::string& fragment) {
  return e.message.find(fragment) != std::string::npos;
}

TEST(Profile, SmallDocumentIsValid) {
  const Expected<Profile> p = parse_profile(small().dump(), "ok.json");
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  EXPECT_EQ(p->sync_round_trip, Duration{12'500});
  EXPECT_EQ(p->find("encoder")->at(2).p99, microseconds{5});
  EXPECT_FALSE(p->shared_memory.has_value());
  EXPECT_DOUBLE_EQ(p->profile_wall_s, 0.0);
}

TEST(Profile, WrongSchema) {
  auto doc = small();
  doc["schema"] = 2;
  const Error e = error_of(doc);
  EXPECT_EQ(e.file, "bad.json");
  EXPECT_TRUE(mentions(e, "schema 2")) << e.message;
  doc.erase("schema");
  EXPECT_TRUE(mentions(error_of(doc), "missing key 'schema'"));
}

TEST(Profile, NonMonotoneStats) {
  auto doc = small();
  doc["units"]["encoder"][1]["p95_us"] = 5.5;  // above p99
  const Error e = error_of(doc);
  EXPECT_TRUE(mentions(e, "units.encoder[1]")) << e.message;
  EXPECT_TRUE(mentions(e, "min <= p50 <= p95 <= p99 <= max")) << e.message;
  doc = small();
  doc["units"]["encoder"][0]["mean_us"] = 0.5;  // below min
  EXPECT_TRUE(mentions(error_of(doc), "min <= mean <= max"));
  doc = small();
  doc["units"]["encoder"][0]["min_us"] = -1;
  EXPECT_TRUE(mentions(error_of(doc), ">= 0"));
}

TEST(Profile, BatchesMustStartAtOneWithoutGaps) {
  auto doc = small();
  doc["units"]["encoder"].erase(0);  // only batch 2 left
  const Error e = error_of(doc);
  EXPECT_TRUE(mentions(e, "batch sizes must run 1, 2")) << e.message;
  doc = small();
  doc["units"]["encoder"][1]["batch"] = 3;
  EXPECT_TRUE(mentions(error_of(doc), "entry 1 has batch 3"));
  doc = small();
  doc["units"]["encoder"] = nlohmann::json::array();
  EXPECT_TRUE(mentions(error_of(doc), "non-empty"));
}

TEST(Profile, WrongTypesAndUnknownKeys) {
  auto doc = small();
  doc["units"]["encoder"][0]["p50_us"] = "fast";
  EXPECT_TRUE(mentions(error_of(doc), "p50_us: must be a number"));
  doc = small();
  doc["unit"] = 1;
  EXPECT_TRUE(mentions(error_of(doc), "unknown key 'unit'"));
  EXPECT_TRUE(mentions(error_of(nlohmann::json::array()), "must be a JSON object"));
}

// A profile that parses but says something wrong names the line of the value (it named the
// file alone): the value itself, the key an "unknown key" error is about, or the nearest
// enclosing value that exists.
TEST(Profile, ValueErrorsHaveALine) {
  auto doc = small();
  doc["units"]["encoder"][1]["p95_us"] = 5.5;  // above p99
  doc["units"]["encoder"][0]["p50_us"] = "fast";
  const std::string text = doc.dump(2);
  auto line_of = [&](const std::string& needle) {
    const std::size_t at = text.find(needle);
    EXPECT_NE(at, std::string::npos) << needle;
    return 1 + static_cast<int>(
                   std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
  };
  Expected<Profile> p = parse_profile(text, "lines.json");
  ASSERT_FALSE(p.has_value());
  EXPECT_TRUE(mentions(p.error(), "units.encoder[0].p50_us: must be a number"))
      << p.error().message;
  EXPECT_EQ(p.error().line, line_of("\"fast\""));
  doc["units"]["encoder"][0]["p50_us"] = 2.0;
  const std::string second = doc.dump(2);
  p = parse_profile(second, "lines.json");
  ASSERT_FALSE(p.has_value());
  EXPECT_TRUE(mentions(p.error(), "units.encoder[1]")) << p.error().message;
  // The entry's object starts on the line of the second '{' under "encoder".
  const std::size_t enc = second.find("\"encoder\"");
  const std::size_t entry = second.find('{', second.find('{', enc) + 1);
  EXPECT_EQ(p.error().line,
            1 + static_cast<int>(std::count(
                    second.begin(), second.begin() + static_cast<std::ptrdiff_t>(entry), '\n')));
  doc = small();
  doc["unit"] = 1;
  const std::string third = doc.dump(2);
  p = parse_profile(third, "lines.json");
  ASSERT_FALSE(p.has_value());
  EXPECT_TRUE(mentions(p.error(), "unknown key 'unit'")) << p.error().message;
  EXPECT_EQ(p.error().line,
            1 + static_cast<int>(std::count(
                    third.begin(),
                    third.begin() + static_cast<std::ptrdiff_t>(third.find("\"unit\"")), '\n')));
}

// A unit named like a path ("enc[x", "a.b") is no index or key the locator can follow: the
// error keeps the nearest line it finds, and nothing throws.
TEST(Profile, ValueErrorsInOddlyNamedUnitsStillParse) {
  for (const std::string name : {"enc[x", "enc[99999999999999999999999]", "a.b", "[", "]"}) {
    auto doc = small();
    doc["units"][name] = doc["units"]["encoder"];
    doc["units"][name][0]["p50_us"] = "fast";
    const Expected<Profile> p = parse_profile(doc.dump(2), "odd.json");
    ASSERT_FALSE(p.has_value()) << name;
    EXPECT_TRUE(mentions(p.error(), "must be a number")) << p.error().message;
    EXPECT_GT(p.error().line, 0) << "at least the enclosing \"units\" is found";
  }
}

TEST(Profile, JsonSyntaxErrorHasALine) {
  const std::string text =
      "{\n  \"schema\": 1,\n  \"units\": {\n    \"encoder\": [1, 2,]\n  }\n}\n";
  const Expected<Profile> p = parse_profile(text, "syntax.json");
  ASSERT_FALSE(p.has_value());
  EXPECT_EQ(p.error().file, "syntax.json");
  EXPECT_EQ(p.error().line, 4);
  EXPECT_TRUE(mentions(p.error(), "JSON syntax error")) << p.error().message;
  const Expected<Profile> empty = parse_profile("", "empty.json");
  ASSERT_FALSE(empty.has_value());
  EXPECT_TRUE(mentions(empty.error(), "JSON syntax error"));
}

TEST(Profile, CoverageNamesTheMissingHead) {
  const Expected<Scenario> s = parse_scenario(R"(name: cover
duration_s: 10
model: {builtin: mimonet, heads: [lane, det, depth]}
sensors: {camera: {rate_hz: 10}}
operations:
  - name: drive
    trigger: camera
    deadline_ms: 100
    nodes: {L: {head: lane, sensor: camera}, P: {cost_ms: 1}}
events:
  - {at_s: 1, add_nodes: {operation: drive, nodes: {D: {head: depth, sensor: camera}}}}
)",
                                              "cover.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  const Profile p = default_profile();
  // `depth` is used only after an event: coverage still sees it.
  const auto e = check_profile_covers(p, *s);
  ASSERT_TRUE(e.has_value());
  EXPECT_TRUE(mentions(*e, "'head/depth'")) << e->message;
  EXPECT_TRUE(mentions(*e, "node 'D'")) << e->message;

  Profile no_encoder = p;
  no_encoder.units.erase("encoder");
  const auto e2 = check_profile_covers(no_encoder, *s);
  ASSERT_TRUE(e2.has_value());
  EXPECT_TRUE(mentions(*e2, "'encoder'")) << e2->message;

  Profile full = p;
  full.units["head/depth"] = full.units["head/det"];
  EXPECT_FALSE(check_profile_covers(full, *s).has_value());
}

}  // namespace
}  // namespace red
