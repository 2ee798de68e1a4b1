#include "red/report/stream.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string_view>

#include <fmt/format.h>

#include "red/core/output_file.hpp"
#include "red/report/report.hpp"

#include "job_columns.hpp"

namespace red {

namespace {

// Opens `path` for writing from scratch; -1 and errno on failure.
int open_truncated(const std::string& path) {
  return ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
}

// Writes all of `text`; false (errno set) on failure.
bool write_all(int fd, const std::string& text) {
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  return true;
}

}  // namespace

CsvRowStream::CsvRowStream(const Scenario& s, std::size_t window, const Clock* clock)
    : scenario_(s), clock_(clock != nullptr ? clock : &own_clock_), window_(window) {
  last_write_ = clock_->now();
}

Expected<std::unique_ptr<CsvRowStream>> CsvRowStream::open(const std::string& dir,
                                                           const Scenario& s, bool units,
                                                           std::size_t window, const Clock* clock) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return Error{dir, 0, "cannot create directory: " + ec.message()};
  std::unique_ptr<CsvRowStream> out(new CsvRowStream(s, window, clock));
  out->with_units_ = units;
  auto start = [&dir, &out](File& f, const std::string& name,
                            const std::string& header) -> std::optional<Error> {
    f.name = name;
    f.path = (std::filesystem::path(dir) / name).string();
    f.partial = partial_path(f.path);
    f.fd = open_truncated(f.partial);
    if (f.fd < 0) return Error{f.partial, 0, "cannot open for writing: " + system_reason(errno)};
    f.buffer.reserve(kBufferBytes + 1024);
    // A header that cannot be written (a full disk) stops this file as a later row would:
    // the run goes on, flush() returns the error.
    f.buffer = header;
    out->write_out(f);
    return std::nullopt;
  };
  if (auto e = start(out->jobs_, "jobs.csv", jobs_csv_header())) return *e;
  if (units)
    if (auto e = start(out->units_, "units.csv", units_csv_header())) return *e;
  return out;
}

CsvRowStream::~CsvRowStream() {
  (void)flush();
  for (File* f : {&jobs_, &units_})
    if (f->fd >= 0) ::close(f->fd);
}

void CsvRowStream::begin_policy(std::string policy) {
  policy_ = std::move(policy);
  policies_.push_back(policy_);
  if (!overflowed_) kept_.push_back({policy_, {}, {}});
}

void CsvRowStream::write_out(File& f) {
  if (f.fd < 0 || f.buffer.empty()) return;
  if (!write_all(f.fd, f.buffer)) {
    // This file stops here (its later rows are dropped); the run and the other file go on.
    const int err = errno;
    if (!error_) error_ = Error{f.partial, 0, "write failed: " + system_reason(err)};
    f.failed = true;
    ::close(f.fd);
    f.fd = -1;
  }
  f.buffer.clear();
}

void CsvRowStream::flush_if_due() {
  const TimePoint now = clock_->now();
  if (now - last_write_ < kFlushInterval) return;
  write_out(jobs_);
  write_out(units_);
  last_write_ = now;
}

void CsvRowStream::poll() {
  flush_if_due();
}

void CsvRowStream::keep(bool job, const JobRow* j, const UnitRow* u) {
  if (overflowed_ || kept_.empty()) return;
  if (kept_rows_ >= window_) {
    // Past the window the report reads the rows back from the files instead (rows()).
    overflowed_ = true;
    kept_ = {};
    kept_rows_ = 0;
    return;
  }
  ++kept_rows_;
  if (job)
    kept_.back().jobs.push_back(*j);
  else
    kept_.back().units.push_back(*u);
}

void CsvRowStream::on_job_row(const JobRow& row) {
  ++job_rows_;
  if (!jobs_.failed) append_job_row(jobs_.buffer, scenario_, policy_, row);
  if (jobs_.buffer.size() >= kBufferBytes) write_out(jobs_);
  flush_if_due();
  keep(true, &row, nullptr);
}

void CsvRowStream::on_unit_row(const UnitRow& row) {
  if (!with_units_) return;
  ++unit_rows_;
  if (!units_.failed) append_unit_row(units_.buffer, scenario_, policy_, row);
  if (units_.buffer.size() >= kBufferBytes) write_out(units_);
  flush_if_due();
  keep(false, nullptr, &row);
}

std::optional<Error> CsvRowStream::flush() {
  write_out(jobs_);
  write_out(units_);
  last_write_ = clock_->now();
  return error_;
}

std::optional<Error> CsvRowStream::finish() {
  (void)flush();
  for (File* f : {&jobs_, &units_}) {
    if (f->fd < 0 || f->renamed) continue;
    // close() can report a delayed write error (NFS, some full file systems).
    if (::close(f->fd) != 0) {
      const int err = errno;
      if (!error_) error_ = Error{f->partial, 0, "write failed: " + system_reason(err)};
      f->failed = true;
    }
    f->fd = -1;
    if (f->failed) continue;
    if (std::rename(f->partial.c_str(), f->path.c_str()) != 0) {
      const int err = errno;
      if (!error_)
        error_ =
            Error{f->path, 0, "cannot rename " + f->partial + " into place: " + system_reason(err)};
      continue;
    }
    f->renamed = true;
    finished_.push_back(f->name);
  }
  return error_;
}

std::size_t CsvRowStream::kept() const noexcept {
  return kept_rows_;
}

Expected<std::vector<StreamedRows>> CsvRowStream::rows() const {
  if (!overflowed_) return kept_;
  for (const File* f : {&jobs_, &units_})
    if (f->failed)
      return Error{f->partial, 0, "cannot read the rows back: an earlier write failed"};
  auto jobs = read_job_rows(jobs_.renamed ? jobs_.path : jobs_.partial, scenario_);
  if (!jobs) return jobs.error();
  std::vector<std::pair<std::string, std::vector<UnitRow>>> units;
  if (with_units_) {
    auto u = read_unit_rows(units_.renamed ? units_.path : units_.partial, scenario_);
    if (!u) return u.error();
    units = std::move(u.value());
  }
  // One entry per policy run, in order, whether or not it left rows.
  std::vector<StreamedRows> out;
  std::size_t ji = 0, ui = 0;
  for (const std::string& p : policies_) {
    StreamedRows r{p, {}, {}};
    if (ji < jobs->size() && (*jobs)[ji].first == p) r.jobs = std::move((*jobs)[ji++].second);
    if (ui < units.size() && units[ui].first == p) r.units = std::move(units[ui++].second);
    out.push_back(std::move(r));
  }
  return out;
}

namespace {

// One RFC 4180 line as fields; nullopt when a quote is left open.
std::optional<std::vector<std::string>> fields(const std::string& line) {
  std::vector<std::string> f(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        f.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        f.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      f.emplace_back();
    } else if (c != '\r') {
      f.back() += c;
    }
  }
  if (quoted) return std::nullopt;
  return f;
}

// Reads `path` line by line: checks the header, then calls `row(fields, line_number)` for
// each row; a row's Error stops the reading. The header may stop short of `header` (a file
// written before its last columns were added) after `least` columns at least: the rows then
// have as many fields as it, and `parse` sees only those.
template <typename Row>
Expected<std::vector<std::pair<std::string, std::vector<Row>>>> read_rows(
    const std::string& path, const char* what, const std::string& header, std::size_t least,
    const std::function<std::optional<Error>(const std::vector<std::string>&, int, Row&)>& parse) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Error{path, 0, "cannot open for reading"};
  std::string line;
  const std::string full(std::string_view(header).substr(0, header.size() - 1));
  const auto expected = fields(full);
  std::optional<std::vector<std::string>> got;
  if (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    got = fields(line);
  }
  const bool prefix = got && expected && got->size() >= least && got->size() <= expected->size() &&
                      std::equal(got->begin(), got->end(), expected->begin());
  if (!prefix) return Error{path, 1, fmt::format("not a {} (header '{}' expected)", what, full)};
  const std::size_t columns = got->size();
  std::vector<std::pair<std::string, std::vector<Row>>> out;
  for (int n = 2; std::getline(in, line); ++n) {
    if (line.empty()) continue;
    const auto f = fields(line);
    if (!f) return Error{path, n, "a quoted field is not closed"};
    if (f->size() != columns)
      return Error{path, n, fmt::format("{} fields, {} expected", f->size(), columns)};
    Row r;
    try {
      if (auto e = parse(*f, n, r)) return *e;
    } catch (const std::exception&) {
      return Error{path, n, "a number is malformed"};
    }
    if (out.empty() || out.back().first != (*f)[0]) out.push_back({(*f)[0], {}});
    out.back().second.push_back(std::move(r));
  }
  return out;
}

TimePoint at_ms(const std::string& v) {
  return TimePoint{from_ms(std::stod(v))};
}

}  // namespace

Expected<std::vector<std::pair<std::string, std::vector<JobRow>>>> read_job_rows(
    const std::string& path, const Scenario& s) {
  return read_rows<JobRow>(
      path, "jobs.csv", jobs_csv_header(), report_detail::kJobColumnsRequired,
      [&](const std::vector<std::string>& f, int n, JobRow& r) -> std::optional<Error> {
        for (std::size_t i = 0; i < f.size(); ++i) {
          const auto read = report_detail::kJobColumns[i].read;
          if (read == nullptr) continue;
          if (auto problem = read(s, f[i], r)) return Error{path, n, *problem};
        }
        return std::nullopt;
      });
}

Expected<std::vector<std::pair<std::string, std::vector<UnitRow>>>> read_unit_rows(
    const std::string& path, const Scenario& s) {
  return read_rows<UnitRow>(
      path, "units.csv", units_csv_header(), 13,
      [&](const std::vector<std::string>& f, int n, UnitRow& r) -> std::optional<Error> {
        r.dispatch = std::stoull(f[1]);
        r.lane = std::stoi(f[2]);
        r.decided = at_ms(f[3]);
        r.start = at_ms(f[4]);
        r.end = at_ms(f[5]);
        bool known = false;
        for (UnitKind k :
             {UnitKind::Encoder, UnitKind::Head, UnitKind::Coarse, UnitKind::Mono, UnitKind::Plain})
          if (f[6] == to_string(k)) {
            r.kind = k;
            known = true;
          }
        if (!known) return Error{path, n, "unknown unit kind '" + f[6] + "'"};
        r.head = -1;
        for (std::size_t h = 0; h < s.model.heads.size(); ++h)
          if (s.model.heads[h] == f[7]) r.head = static_cast<int>(h);
        if (!f[7].empty() && r.head < 0) return Error{path, n, "unknown head '" + f[7] + "'"};
        r.batch = std::stoi(f[8]);
        r.members = std::stoi(f[9]);
        r.round_trip = f[10] == "1";
        known = false;
        for (UnitStatus st : {UnitStatus::Completed, UnitStatus::Failed, UnitStatus::OutOfMemory,
                              UnitStatus::Cancelled, UnitStatus::Unfinished})
          if (f[11] == to_string(st)) {
            r.status = st;
            known = true;
          }
        if (!known) return Error{path, n, "unknown status '" + f[11] + "'"};
        r.jobs = f[12];
        if (f.size() > 13 && !f[13].empty()) r.expected = from_ms(std::stod(f[13]));
        return std::nullopt;
      });
}

}  // namespace red
