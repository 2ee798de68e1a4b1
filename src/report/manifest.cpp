#include "red/report/manifest.hpp"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <filesystem>
#include <random>
#include <utility>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "red/core/output_file.hpp"

namespace red {

namespace fs = std::filesystem;

std::string new_run_id() {
  std::random_device rd;
  const std::uint64_t hi = rd();
  const std::uint64_t lo = rd();
  return fmt::format("{:016x}", (hi << 32) ^ lo);
}

namespace {

// The wall-clock time now, UTC, to the second: when the run started, for the reader (the
// scheduler never sees it).
std::string utc_now() {
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&t, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

}  // namespace

OutputSet::OutputSet(std::string dir, std::string command, std::string run_id)
    : dir_(std::move(dir)),
      command_(std::move(command)),
      run_id_(std::move(run_id)),
      started_(utc_now()) {}

Expected<OutputSet> OutputSet::begin(const std::string& dir, std::string command) {
  return reopen(dir, std::move(command), new_run_id());
}

Expected<OutputSet> OutputSet::reopen(const std::string& dir, std::string command,
                                      std::string run_id) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return Error{dir, 0, "cannot create directory: " + ec.message()};
  OutputSet set(dir, std::move(command), std::move(run_id));
  // Before any other file of this run: the old manifest no longer describes the directory.
  const std::string path = (fs::path(dir) / kManifestName).string();
  if (write_file_atomically(path, set.manifest_json())) {
    fs::remove(path, ec);
    if (ec) return Error{path, 0, "cannot remove the previous run's manifest: " + ec.message()};
  }
  set.files_.clear();
  return set;
}

void OutputSet::add(const std::string& relative) {
  if (std::find(files_.begin(), files_.end(), relative) == files_.end()) files_.push_back(relative);
}

void OutputSet::fail(const Error& e) {
  failures_.push_back(e);
}

std::string OutputSet::manifest_json() const {
  nlohmann::ordered_json files = nlohmann::ordered_json::array();
  bool complete = failures_.empty() && !files_.empty();
  for (const std::string& f : files_) {
    std::error_code ec;
    const auto bytes = fs::file_size(fs::path(dir_) / f, ec);
    if (ec) {
      complete = false;
      continue;
    }
    files.push_back({{"path", f}, {"bytes", bytes}});
  }
  nlohmann::ordered_json errors = nlohmann::ordered_json::array();
  for (const Error& e : failures_) errors.push_back(e.to_string());
  nlohmann::ordered_json doc{{"schema", 1},
                             {"run_id", run_id_},
                             {"started", started_},
                             {"command", command_},
                             {"complete", complete}};
  doc["stopped_by"] = stopped_ ? nlohmann::ordered_json(*stopped_) : nlohmann::ordered_json();
  doc["files"] = std::move(files);
  doc["errors"] = std::move(errors);
  return doc.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n";
}

std::optional<Error> OutputSet::finish() {
  return write_file_atomically((fs::path(dir_) / kManifestName).string(), manifest_json());
}

}  // namespace red
