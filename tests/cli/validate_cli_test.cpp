// `red validate` checks everything a run needs that can be checked without running (issue 40,
// item 2; docs/MODELS.md, "What red validate checks"): the model manifest and the files it
// names, the scenario's heads and input against it, and that the profile is of this model and
// input. Each failure is bad input (exit 2) naming the file and line. The manifests, TorchScript
// files (empty: they are only checked to exist) and profiles are written into a scratch
// directory per test.

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <fmt/format.h>

#include "../support/cli.hpp"
#include "red/profile/profile.hpp"

namespace red {
namespace {

namespace fs = std::filesystem;
using test::quote;
using test::read_text;

using Result = test::RunResult;

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

/// 1-based line of the first line of `text` holding `fragment` (0: none).
int line_of(const std::string& text, const std::string& fragment) {
  std::istringstream in(text);
  int n = 0;
  for (std::string line; std::getline(in, line);) {
    ++n;
    if (contains(line, fragment)) return n;
  }
  return 0;
}

/// What the scenario of a test says about its model.
struct ModelText {
  std::string manifest = "m.yaml";
  std::string heads = "[a, b]";
  std::string input;               ///< empty: no input key
  std::string profile = "p.json";  ///< empty: no profile key
};

class ValidateCli : public test::ScratchTest {
 protected:
  void SetUp() override {
    ScratchTest::SetUp();
    for (const char* f : {"enc.pt", "a.pt", "b.pt"}) write(f, "not loaded by validate\n");
    write("m.yaml", "encoder: enc.pt\nheads: {a: a.pt, b: b.pt}\ninput: [3, 64, 128]\n");
  }
  fs::path write(const std::string& name, const std::string& text) {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p;
  }

  /// A profile whose model label is `label`, with units for heads a and b (the built-in
  /// profile's lane figures).
  fs::path write_profile(const std::string& name, const std::string& label) {
    Profile p = default_profile();
    p.source = "measured";
    p.model = label;
    const auto units = p.units;
    for (const auto& [unit, figures] : units) {
      const std::string suffix = "/lane";
      if (unit.size() > suffix.size() &&
          unit.compare(unit.size() - suffix.size(), suffix.size(), suffix) == 0) {
        const std::string base = unit.substr(0, unit.size() - suffix.size());
        p.units[base + "/a"] = figures;
        p.units[base + "/b"] = figures;
      }
    }
    return write(name, profile_to_json(p));
  }

  /// Writes s.yaml, a scenario of one operation running heads a and b on a manifest model.
  fs::path write_scenario(const ModelText& m) {
    std::string text = "name: t\nduration_s: 1\nmodel:\n  manifest: " + m.manifest +
                       "\n  heads: " + m.heads + "\n";
    if (!m.input.empty()) text += "  input: " + m.input + "\n";
    if (!m.profile.empty()) text += "profile: " + m.profile + "\n";
    text +=
        "sensors:\n  camera: {rate_hz: 10}\noperations:\n  - name: op\n    trigger: camera\n"
        "    deadline_ms: 500\n    nodes:\n      A: {head: a, sensor: camera}\n"
        "      B: {head: b, sensor: camera}\n    edges: [[A, B]]\n";
    scenario_text_ = text;
    return write("s.yaml", text);
  }

  Result red(const std::string& args) { return test::run_red(args, dir_); }

  /// `red ARGS` exits 2 with `fragment` on stderr and no "ok" on stdout.
  void expect_bad(const std::string& args, const std::string& fragment) {
    SCOPED_TRACE("red " + args);
    const Result r = red(args);
    ASSERT_TRUE(r.exited) << r.err;
    EXPECT_EQ(r.code, 2) << "stderr: " << r.err << "\nstdout: " << r.out;
    EXPECT_TRUE(contains(r.err, fragment)) << "stderr: " << r.err << "\nexpected: " << fragment;
    EXPECT_FALSE(contains(r.out, "\nok")) << r.out;
  }

  /// "DIR/s.yaml:N: " for the line of the scenario holding `fragment`.
  std::string at_scenario(const std::string& fragment) const {
    const int line = line_of(scenario_text_, fragment);
    EXPECT_GT(line, 0) << fragment;
    return fmt::format("{}:{}: ", (dir_ / "s.yaml").string(), line);
  }

  std::string scenario_path() const { return quote((dir_ / "s.yaml").string()); }

  std::string scenario_text_;
};

TEST_F(ValidateCli, AManifestModelWithItsProfileIsOkAndEveryCheckIsListed) {
  write_profile("p.json", "m.yaml [3,64,128]");
  write_scenario({});
  const Result r = red("validate " + scenario_path());
  ASSERT_TRUE(r.exited);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "manifest " + (dir_ / "m.yaml").string() + ": read, 2 head(s)"))
      << r.out;
  EXPECT_TRUE(contains(r.out, "files: encoder " + (dir_ / "enc.pt").string())) << r.out;
  EXPECT_TRUE(contains(r.out, "heads: a, b in the manifest")) << r.out;
  EXPECT_TRUE(contains(r.out, "input: [3,64,128] taken from the manifest")) << r.out;
  EXPECT_TRUE(contains(r.out,
                       "is of m.yaml [3,64,128], the scenario's model is m.yaml "
                       "[3,64,128]"))
      << r.out;
  EXPECT_TRUE(r.out.size() >= 3 && r.out.substr(r.out.size() - 3) == "ok\n") << r.out;
  EXPECT_TRUE(r.err.empty()) << r.err;
  // The same scenario simulates (the check runs for every command that loads a scenario).
  const Result sim = red("simulate " + scenario_path() + " --policy red");
  EXPECT_EQ(sim.code, 0) << sim.err;
}

TEST_F(ValidateCli, AnInputEqualToTheManifestsIsOk) {
  write_profile("p.json", "m.yaml [3,64,128]");
  ModelText m;
  m.input = "[3, 64, 128]";
  write_scenario(m);
  const Result r = red("validate " + scenario_path());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "input: [3,64,128] equals the manifest's")) << r.out;
}

TEST_F(ValidateCli, AMissingManifestIsAnErrorAtTheManifestLine) {
  ModelText m;
  m.manifest = "nowhere.yaml";
  write_scenario(m);
  expect_bad("validate " + scenario_path(),
             at_scenario("manifest:") + "model.manifest: the model manifest '" +
                 (dir_ / "nowhere.yaml").string() + "' does not exist");
}

TEST_F(ValidateCli, AManifestNamingAMissingFileIsAnErrorAtTheManifestsLine) {
  const std::string manifest =
      "encoder: enc.pt\nheads:\n  a: a.pt\n  b: gone.pt\ninput: [3, 64, 128]\n";
  write("m.yaml", manifest);
  write_profile("p.json", "m.yaml [3,64,128]");
  write_scenario({});
  expect_bad("validate " + scenario_path(),
             fmt::format("{}:{}: head 'b' file 'gone.pt' not found", (dir_ / "m.yaml").string(),
                         line_of(manifest, "gone.pt")));
}

TEST_F(ValidateCli, AHeadTheManifestDoesNotHaveIsAnErrorAtTheHeadsLine) {
  write_profile("p.json", "m.yaml [3,64,128]");
  ModelText m;
  m.heads = "[a, b, c]";  // c: listed, not in the manifest (the nodes use a and b)
  write_scenario(m);
  expect_bad("validate " + scenario_path(),
             at_scenario("heads:") + "model.heads: head 'c' is not in the model manifest");
  const Result r = red("validate " + scenario_path());
  EXPECT_TRUE(contains(r.err, "(its heads: a, b)")) << r.err;
}

TEST_F(ValidateCli, AnInputOtherThanTheManifestsIsAnErrorAtTheInputLine) {
  write_profile("p.json", "m.yaml [3,64,128]");
  ModelText m;
  m.input = "[3, 32, 64]";
  write_scenario(m);
  expect_bad("validate " + scenario_path(),
             at_scenario("input:") +
                 "model.input: [3,32,64] is not the input of the model "
                 "manifest");
}

TEST_F(ValidateCli, AProfileOfAnotherModelIsAnErrorAtTheProfileLine) {
  write_profile("p.json", "mimonet [3,64,128]");
  write_scenario({});
  expect_bad("validate " + scenario_path(),
             at_scenario("profile:") + "profile " + (dir_ / "p.json").string() +
                 " is of mimonet [3,64,128]; the scenario's model is m.yaml [3,64,128] "
                 "(another model");
  // Given on the command line, the error names --profile.
  write_profile("q.json", "other.yaml [3,64,128]");
  const std::string q = (dir_ / "q.json").string();
  expect_bad("validate " + scenario_path() + " --profile " + quote(q),
             "--profile: profile " + q + " is of other.yaml [3,64,128]");
  // A built-in model with a profile of a manifest model is refused the same way.
  const std::string builtin =
      "name: t\nduration_s: 1\nmodel: {builtin: mimonet, heads: [lane]}\nprofile: p.json\n"
      "sensors:\n  camera: {rate_hz: 10}\noperations:\n  - name: op\n    trigger: camera\n"
      "    deadline_ms: 500\n    nodes:\n      L: {head: lane, sensor: camera}\n";
  write("b.yaml", builtin);
  write_profile("p.json", "m.yaml [3,192,384]");
  expect_bad(
      "validate " + quote((dir_ / "b.yaml").string()),
      fmt::format("{}:{}: profile", (dir_ / "b.yaml").string(), line_of(builtin, "profile:")) +
          " " + (dir_ / "p.json").string() +
          " is of m.yaml [3,192,384]; the scenario's model is mimonet [3,192,384]");
}

TEST_F(ValidateCli, AProfileOfAnotherInputSizeIsAnErrorAtTheProfileLine) {
  write_profile("p.json", "m.yaml [3,128,256]");
  write_scenario({});
  expect_bad("validate " + scenario_path(),
             at_scenario("profile:") + "profile " + (dir_ / "p.json").string() +
                 " is of m.yaml [3,128,256]; the scenario's model is m.yaml [3,64,128] "
                 "(another input size");
}

TEST_F(ValidateCli, AManifestModelWithNoProfileIsRefusedForEveryCommand) {
  ModelText m;
  m.profile.clear();
  write_scenario(m);
  const std::string where = at_scenario("manifest:") + "model.manifest: the model '" +
                            (dir_ / "m.yaml").string() + "' has no profile";
  expect_bad("validate " + scenario_path(), where);
  const Result r = red("validate " + scenario_path());
  EXPECT_TRUE(
      contains(r.err, "red profile --model " + (dir_ / "m.yaml").string() + " --out P.json"))
      << r.err;
  EXPECT_TRUE(contains(r.err, "profile: P.json")) << r.err;
  // Not simulated on the built-in MIMONet's costs either.
  expect_bad("simulate " + scenario_path() + " --policy red", where);
  expect_bad("analyze " + scenario_path(), where);
  // --profile makes it whole.
  const fs::path p = write_profile("p.json", "m.yaml [3,64,128]");
  const Result ok = red("validate " + scenario_path() + " --profile " + quote(p.string()));
  EXPECT_EQ(ok.code, 0) << ok.err;
}

TEST_F(ValidateCli, AProfileLabelThatDoesNotParseIsAWarning) {
  write_profile("p.json", "my hand-written profile");
  write_scenario({});
  const Result r = red("validate " + scenario_path());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(contains(r.err, "red: warning: profile " + (dir_ / "p.json").string() +
                                  " does not say which model it was measured on"))
      << r.err;
  EXPECT_TRUE(contains(r.out, "ok, with 1 warning(s) on stderr")) << r.out;
}

TEST(ProfileLabel, ParsesWhatRedProfileWrites) {
  const auto a = parse_profile_label("model.yaml [3,128,256]");
  ASSERT_TRUE(a.has_value());
  EXPECT_EQ(a->model, "model.yaml");
  EXPECT_EQ(a->input, (std::vector<std::int64_t>{3, 128, 256}));
  EXPECT_FALSE(a->separate);
  const auto b = parse_profile_label("my model.yaml [1,2,3] separate");
  ASSERT_TRUE(b.has_value());
  EXPECT_EQ(b->model, "my model.yaml");
  EXPECT_TRUE(b->separate);
  for (const char* bad : {"", "mimonet", "mimonet [3,192]", "mimonet [3,0,4]", "[3,4,5]",
                          "mimonet [3,x,4]", "mimonet [3,4,5] twice", "mimonet [3,4,5,]"})
    EXPECT_FALSE(parse_profile_label(bad).has_value()) << bad;
  EXPECT_TRUE(parse_profile_label(default_profile().model).has_value());
}

}  // namespace
}  // namespace red
