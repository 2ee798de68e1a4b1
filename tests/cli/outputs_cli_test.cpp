// The output directory of `red simulate`, `red compare`, `red run`, `red sweep` and
// `red analyze`, run as a real process (issue 39 items 3 and 4): every file renamed into
// place whole (no .partial left), marked with the run's id, and ended by a manifest.json
// that lists them; a file that cannot be written (its partial name leads to /dev/full, as
// on a full disk) costs that file only: the table still goes to stdout, the summary to the
// directory or to stderr, the error names the path and the system's reason, exit code 1.

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include <fmt/format.h>

#include "../support/cli.hpp"

namespace red {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::quote;
using test::read_text;
using test::scenario;

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

class OutputsCli : public test::ScratchTest {
 protected:
  // Runs `red ARGS` (by default no gnuplot: the plots' data and scripts only); the exit
  // code, with stdout and stderr in out_ and err_.
  int red(const std::string& args, const std::string& env = "RED_GNUPLOT=none") {
    const test::RunResult r = test::run_red(args, dir_, env + " timeout 300");
    out_ = r.out;
    err_ = r.err;
    return r.code;
  }

  // The manifest of `out`, checked against the directory: each file listed exists with
  // the size given, and no .partial file is left anywhere.
  json manifest(const fs::path& out) {
    json m;
    EXPECT_NO_THROW(m = json::parse(read_text(out / "manifest.json")));
    for (const json& f : m["files"]) {
      const fs::path p = out / f["path"].get<std::string>();
      EXPECT_TRUE(fs::exists(p)) << p;
      if (fs::exists(p)) {
        EXPECT_EQ(fs::file_size(p), f["bytes"].get<std::uintmax_t>()) << p;
      }
    }
    return m;
  }

  static std::vector<std::string> partial_files(const fs::path& out) {
    std::vector<std::string> left;
    for (const auto& e : fs::recursive_directory_iterator(out))
      if (e.path().extension() == ".partial") left.push_back(e.path().string());
    return left;
  }

  static std::vector<std::string> listed(const json& m) {
    std::vector<std::string> names;
    for (const json& f : m["files"]) names.push_back(f["path"].get<std::string>());
    return names;
  }

  std::string out_, err_;
};

TEST_F(OutputsCli, CompareMarksItsFilesAsOneSet) {
  const fs::path out = dir_ / "out";
  const std::string args = "compare " + scenario("minibench-tight.yaml") +
                           " --policies edf,red --out " + quote(out.string());
  ASSERT_EQ(red(args), 0) << err_;
  const json m = manifest(out);
  EXPECT_TRUE(m["complete"].get<bool>()) << m.dump();
  EXPECT_EQ(m["command"], "compare");
  EXPECT_TRUE(m["stopped_by"].is_null());
  const std::string id = m["run_id"];
  const auto names = listed(m);
  for (const char* f : {"summary.json", "jobs.csv", "units.csv", "trace.json", "index.html"})
    EXPECT_NE(std::find(names.begin(), names.end(), f), names.end()) << f << "\n" << m.dump();
  EXPECT_TRUE(std::any_of(names.begin(), names.end(),
                          [](const std::string& n) { return n.rfind("plots/", 0) == 0; }));
  EXPECT_TRUE(partial_files(out).empty());
  // The run id in each file whose format has room for it.
  EXPECT_EQ(json::parse(read_text(out / "summary.json"))["run_id"], id);
  EXPECT_EQ(json::parse(read_text(out / "trace.json"))["otherData"]["run_id"], id);
  EXPECT_TRUE(
      contains(read_text(out / "index.html"), "<meta name=\"red-run-id\" content=\"" + id + "\">"));

  // Again into the same directory: a new id, everywhere.
  ASSERT_EQ(red(args), 0) << err_;
  const json again = manifest(out);
  EXPECT_NE(again["run_id"], id);
  EXPECT_EQ(json::parse(read_text(out / "summary.json"))["run_id"], again["run_id"]);
}

TEST_F(OutputsCli, ASummaryThatCannotBeWrittenGoesToStderr) {
  const fs::path out = dir_ / "out";
  fs::create_directories(out);
  fs::create_symlink("/dev/full", out / "summary.json.partial");
  ASSERT_EQ(red("simulate " + scenario("minibench-tight.yaml") + " --policy red --out " +
                quote(out.string())),
            1)
      << err_;
  // The table on stdout, the summary on stderr, the path and the system's reason.
  EXPECT_TRUE(contains(out_, "latency ms:")) << out_;
  EXPECT_TRUE(
      contains(err_, (out / "summary.json").string() + ": write failed: No space left on device"))
      << err_;
  const std::string json_text = err_.substr(err_.find("{\n"));
  json s;
  ASSERT_NO_THROW(s = json::parse(json_text.substr(0, json_text.find("\n}\n") + 2))) << err_;
  EXPECT_EQ(s["policies"][0]["name"], "red");
  // The other files are written; the manifest says the set is not complete, and why.
  EXPECT_TRUE(fs::exists(out / "jobs.csv"));
  EXPECT_FALSE(fs::exists(out / "summary.json"));
  const json m = manifest(out);
  EXPECT_FALSE(m["complete"].get<bool>());
  ASSERT_EQ(m["errors"].size(), 1U) << m.dump();
  EXPECT_TRUE(contains(m["errors"][0], "No space left on device"));
  EXPECT_EQ(s["run_id"], m["run_id"]);
}

// A real run whose jobs.csv cannot be written (a full disk) goes on to the end: the table,
// summary.json with every job, units.csv, and the error once, with the reason.
TEST_F(OutputsCli, ARealRunWhoseRowsCannotBeWrittenGoesOn) {
  const fs::path out = dir_ / "out";
  fs::create_directories(out);
  fs::create_symlink("/dev/full", out / "jobs.csv.partial");
  ASSERT_EQ(red("run " + quote(std::string(RED_TEST_DATA) + "/cli/signal.yaml") +
                " --backend synthetic --policy edf --no-realtime --set duration_s=2 --out " +
                quote(out.string())),
            1)
      << err_;
  EXPECT_TRUE(contains(out_, "completed ")) << out_;
  EXPECT_TRUE(contains(
      err_, (out / "jobs.csv.partial").string() + ": write failed: No space left on device"))
      << err_;
  const json s = json::parse(read_text(out / "summary.json"));
  EXPECT_GT(s["policies"][0]["jobs"].get<int>(), 0);
  EXPECT_GT(read_text(out / "units.csv").size(), 0U);
  EXPECT_FALSE(fs::exists(out / "jobs.csv"));
  const json m = manifest(out);
  EXPECT_FALSE(m["complete"].get<bool>());
  const auto names = listed(m);
  EXPECT_NE(std::find(names.begin(), names.end(), "summary.json"), names.end());
  EXPECT_NE(std::find(names.begin(), names.end(), "units.csv"), names.end());
  EXPECT_EQ(std::find(names.begin(), names.end(), "jobs.csv"), names.end());
}

TEST_F(OutputsCli, SweepAndAnalyzeEndWithAManifest) {
  const fs::path sweep = dir_ / "sweep", an = dir_ / "analyze";
  ASSERT_EQ(red("sweep " + scenario("minibench-tight.yaml") +
                " --set deadline_scale=1:2:1 --policies edf --out " + quote(sweep.string())),
            0)
      << err_;
  const json m = manifest(sweep);
  EXPECT_TRUE(m["complete"].get<bool>()) << m.dump();
  EXPECT_EQ(json::parse(read_text(sweep / "sweep.json"))["run_id"], m["run_id"]);
  EXPECT_TRUE(partial_files(sweep).empty());
  ASSERT_EQ(red("analyze " + scenario("minibench-tight.yaml") + " --out " + quote(an.string())), 0)
      << err_;
  const json a = manifest(an);
  EXPECT_TRUE(a["complete"].get<bool>()) << a.dump();
  EXPECT_EQ(listed(a), std::vector<std::string>{"analysis.json"});
  EXPECT_EQ(json::parse(read_text(an / "analysis.json"))["run_id"], a["run_id"]);
}

// A gnuplot that answers RED's probe for its PNG terminal but cannot draw: every image is a
// lost output, named with gnuplot's complaint, and the run exits 1 (issue 40 item 3; it
// printed a note and exited 0). The rest of the directory is still written.
TEST_F(OutputsCli, APlotGnuplotCannotDrawIsAnError) {
  const fs::path fake = dir_ / "gnuplot";
  {
    std::ofstream f(fake);
    f << "#!/bin/sh\ncase \"$*\" in *-e*) exit 0;; esac\necho 'no room for the image' >&2\n"
         "exit 3\n";
  }
  fs::permissions(fake, fs::perms::owner_all);
  const std::string env = "RED_GNUPLOT=" + quote(fake.string());

  const fs::path out = dir_ / "out";
  EXPECT_EQ(red("compare " + scenario("minibench-tight.yaml") + " --policies edf,red --out " +
                    quote(out.string()),
                env),
            1)
      << err_;
  EXPECT_TRUE(contains(err_, (out / "plots" / "response_hist.png").string() +
                                 ": not drawn: gnuplot failed (exit 3): no room for the image"))
      << err_;
  EXPECT_TRUE(contains(out_, "red")) << "the table still goes to stdout";
  EXPECT_TRUE(fs::exists(out / "summary.json"));
  EXPECT_FALSE(fs::exists(out / "plots" / "response_hist.png"));
  const json m = manifest(out);
  EXPECT_FALSE(m["complete"].get<bool>());
  EXPECT_TRUE(partial_files(out).empty());

  const fs::path sweep = dir_ / "sweep";
  EXPECT_EQ(red("sweep " + scenario("minibench-tight.yaml") +
                    " --set deadline_scale=1:2:1 --policies edf --out " + quote(sweep.string()),
                env),
            1)
      << err_;
  EXPECT_TRUE(contains(err_, "not drawn: gnuplot failed (exit 3)")) << err_;
  EXPECT_TRUE(fs::exists(sweep / "sweep.json"));
}

}  // namespace
}  // namespace red
