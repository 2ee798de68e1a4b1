#include "red/report/redraw.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "red/metrics/why.hpp"
#include "red/report/manifest.hpp"
#include "red/report/plots.hpp"
#include "red/report/schedule_html.hpp"
#include "red/report/stream.hpp"

namespace red {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

namespace {

constexpr std::size_t kMostPhaseWindows = 8;
const Duration kWindow = std::chrono::seconds{2};

// What each file of a run holds, in the order the page lists them.
const std::vector<std::pair<std::string, std::string>>& known_files() {
  static const std::vector<std::pair<std::string, std::string>> k = {
      {"summary.json", "the summary of every policy (schema in docs/REPORTS.md)"},
      {"jobs.csv", "one row per job"},
      {"units.csv", "one row per unit execution"},
      {"trace.json", "the timeline: drag into https://ui.perfetto.dev"},
      {"prediction.json", "the simulator's prediction of this real run (docs/FIDELITY.md)"},
      {"rss.csv", "the process's memory (RSS) sampled during the real run"},
      {"manifest.json", "the list of this run's files with their sizes"}};
  return k;
}

std::string note_for(const std::string& f) {
  for (const auto& [name, note] : known_files())
    if (name == f) return note;
  const std::string ext = fs::path(f).extension().string();
  if (ext == ".dat") return "a plot's data";
  if (ext == ".gp") return "a plot's gnuplot script (run gnuplot on it to redraw)";
  if (ext == ".svg" && f.find("timeline") != std::string::npos) return "a timeline drawing";
  if (ext == ".png" || ext == ".svg") return "a plot";
  return "";
}

// The data files in the page's order: the known ones first, the rest by name.
std::vector<std::string> ordered_data_files(std::vector<std::string> files) {
  std::vector<std::string> out;
  for (const auto& [name, note] : known_files())
    if (std::find(files.begin(), files.end(), name) != files.end()) out.push_back(name);
  std::sort(files.begin(), files.end());
  for (const std::string& f : files)
    if (std::find(out.begin(), out.end(), f) == out.end()) out.push_back(f);
  return out;
}

// The moment a job missed: its deadline, or its finish when earlier (a skipped release).
TimePoint missed_at(const JobRow& j) {
  return std::min(j.deadline, j.finish);
}

bool is_miss(const JobRow& j) {
  return j.outcome != JobOutcome::Met && j.outcome != JobOutcome::Unfinished;
}

// True when `a` is a worse miss than `b` of a run of `s`: the more critical job (at its
// release), then the one that ended latest past its deadline (a late finish before a drop at
// its deadline, a drop before a skipped release), then the earlier release.
bool worse(const Scenario& s, const JobRow& a, const JobRow& b) {
  const int ca = criticality_at(s, a.operation, a.release);
  const int cb = criticality_at(s, b.operation, b.release);
  if (ca != cb) return ca > cb;
  const Duration la = a.finish - a.deadline;
  const Duration lb = b.finish - b.deadline;
  if (la != lb) return la > lb;
  return a.release < b.release;
}

std::string file_stem(const std::string& policy) {
  std::string out;
  for (char c : policy)
    out += (std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '-' || c == '_') ? c : '_';
  return out;
}

ojson table_json(const HtmlTable& t) {
  return {{"caption", t.caption}, {"header", t.header}, {"rows", t.rows}};
}

HtmlTable table_from(const ojson& j) {
  HtmlTable t;
  t.caption = j.at("caption").get<std::string>();
  t.header = j.at("header").get<std::vector<std::string>>();
  t.rows = j.at("rows").get<std::vector<std::vector<std::string>>>();
  return t;
}

}  // namespace

std::vector<TimelineWindow> report_timeline_windows(const Scenario& s,
                                                    const std::vector<TimelineRun>& runs,
                                                    std::optional<std::size_t> phase) {
  TimePoint end = s.warmup;
  for (const TimelineRun& r : runs) end = std::max(end, r.end);
  if (end <= s.warmup) end = s.warmup + kWindow;
  const std::vector<PhaseSpan> spans = workload_phases(s, end);
  std::vector<TimelineWindow> out;
  TimePoint lo = s.warmup;
  TimePoint hi = end;
  for (std::size_t k = 0; k < spans.size(); ++k) {
    if (phase && k != *phase) continue;
    if (!phase && k >= kMostPhaseWindows) break;
    const PhaseSpan& p = spans[k];
    if (phase) {
      lo = p.from;
      hi = p.to;
    }
    const TimePoint to = std::min(end, p.from + kWindow);
    out.push_back({p.from, std::max(to, p.from + std::chrono::milliseconds{1}),
                   fmt::format("timeline_phase{}", k),
                   fmt::format("Timeline: phase {} ({}), its first 2 s", k, phase_label(s, p)),
                   ""});
  }
  for (const TimelineRun& r : runs) {
    if (r.jobs == nullptr) continue;
    const JobRow* w = nullptr;
    for (const JobRow& j : *r.jobs)
      if (is_miss(j) && j.release >= lo && j.release < hi && (w == nullptr || worse(s, j, *w)))
        w = &j;
    if (w == nullptr) continue;
    // From 0.3 s before the miss, so that what led to it is in view when the page opens.
    const TimePoint at = missed_at(*w);
    TimePoint from = std::max(s.warmup, at - std::chrono::milliseconds{300});
    const TimePoint to = std::min(end, from + kWindow);
    from = std::max(s.warmup, std::min(from, to - kWindow));
    out.push_back(
        {from, to, "timeline_worst_" + file_stem(r.policy),
         fmt::format("Timeline of {}: 2 s around its worst miss{}, {}#{} ({} at {:.3f} s)",
                     r.policy, phase ? fmt::format(" in phase {}", *phase) : "",
                     s.operation_name(w->operation), w->seq, to_string(w->outcome), to_s(at)),
         r.policy});
  }
  return out;
}

std::string page_json(const PageInput& in) {
  const Scenario& s = *in.scenario;
  ojson j;
  j["schema"] = 1;
  j["index_html"] = in.index_html;
  j["duration_ns"] = s.duration.count();
  j["warmup_ns"] = s.warmup.count();
  ojson ops = ojson::array();
  for (int i = 0; i < s.operation_count(); ++i) ops.push_back(s.operation_name(i));
  j["operations"] = ops;
  j["lanes"] = s.device.lanes;
  j["heads"] = s.model.heads;
  ojson sensors = ojson::array();
  for (const SensorSpec& x : s.sensors) sensors.push_back(x.name);
  j["sensors"] = sensors;
  // Each operation's criticality at the start (null: added by an event) and the new ones an
  // event gives, for the causes of misses and the worst miss (metrics/why.hpp).
  ojson crit = ojson::array();
  for (const auto& op : s.initial) crit.push_back(op ? ojson(op->criticality) : ojson());
  j["criticality"] = crit;
  ojson events = ojson::array();
  for (const EventSpec& e : s.events) {
    ojson ev = {{"at_ns", e.at.count()}, {"kind", e.kind}};
    ojson changed = ojson::array();
    for (const auto& [op, snapshot] : e.changes)
      if (snapshot) changed.push_back({op, snapshot->criticality});
    if (!changed.empty()) ev["criticality"] = changed;
    events.push_back(std::move(ev));
  }
  j["events"] = events;
  ojson runs = ojson::array();
  for (const PageRun& r : in.runs)
    runs.push_back({{"policy", r.metrics->name}, {"end_ns", r.end.count()}});
  j["runs"] = runs;
  j["verdicts"] = in.verdicts ? table_json(*in.verdicts) : ojson();
  ojson pred = ojson::array();
  for (const HtmlTable& t : in.prediction) pred.push_back(table_json(t));
  j["prediction"] = pred;
  return j.dump();
}

PageReport write_report_page(const std::string& dir, const PageInput& in, const PageOptions& o) {
  PageReport r;
  const Scenario& s = *in.scenario;
  std::vector<PolicyMetrics> metrics;
  for (const PageRun& run : in.runs) metrics.push_back(*run.metrics);
  auto wrote = [&](const std::string& name) { r.files.push_back(name); };

  PlotOptions po;
  po.gnuplot = o.gnuplot;
  std::vector<PlotRun> plot_runs;
  for (std::size_t i = 0; i < in.runs.size(); ++i)
    plot_runs.push_back({metrics[i].name, &metrics[i], in.runs[i].jobs});
  const PlotReport plots = write_run_plots(dir, s, plot_runs, po);
  r.plots_note = plots.note;
  for (const Error& e : plots.errors) r.errors.push_back(e);  // images gnuplot did not draw
  for (const std::string& f : plots.files) wrote(f);
  for (const PlotFile& f : plots.plots) {
    wrote(f.png);
    ++r.images;
    if (!f.svg.empty()) {
      wrote(f.svg);
      ++r.images;
    }
  }

  std::vector<TimelineRun> timeline_runs;
  for (const PageRun& run : in.runs) {
    if (o.policy && run.metrics->name != *o.policy) continue;
    timeline_runs.push_back(
        {run.metrics->name, run.units, run.jobs, run.waits, run.waits_cut, run.end});
  }
  std::vector<TimelineWindow> windows;
  if (o.timeline)
    windows.push_back(
        {o.timeline->first, o.timeline->second, "timeline",
         fmt::format("Timeline: {:g} to {:g} s", to_s(o.timeline->first), to_s(o.timeline->second)),
         ""});
  else
    windows = report_timeline_windows(s, timeline_runs, o.phase);
  auto timelines = write_timelines(dir, s, timeline_runs, windows);
  if (!timelines) {
    r.errors.push_back(timelines.error());
  } else {
    for (const std::string& f : timelines->files) {
      wrote(f);
      ++r.images;
    }
    if (!o.timeline) {
      std::string none;
      for (const TimelineRun& t : timeline_runs) {
        const bool drawn =
            std::any_of(windows.begin(), windows.end(),
                        [&](const TimelineWindow& w) { return w.policy == t.policy; });
        if (!drawn) none += (none.empty() ? "" : ", ") + t.policy;
      }
      timelines->section.paragraphs.push_back(
          "Drawn: the first 2 s of each workload phase with every policy, then each policy alone "
          "around its worst miss (the most critical job that missed, and of those the one that "
          "ended latest past its deadline). Another window: red report DIR --timeline FROM:TO, "
          "or --phase N for one phase." +
          (none.empty() ? std::string() : " No miss to show for: " + none + "."));
    }
  }

  if (in.index_html) {
    std::vector<HtmlLink> links;
    std::vector<std::string> data = in.data_files;
    data.emplace_back(kManifestName);
    for (const std::string& f : ordered_data_files(data)) links.push_back({f, note_for(f)});
    for (const std::string& f : r.files) links.push_back({f, note_for(f)});
    HtmlPage page = compare_page(in.header, metrics, plots, links);
    if (in.verdicts) page.tables.insert(page.tables.begin(), *in.verdicts);
    for (const HtmlTable& t : in.prediction) page.tables.push_back(t);
    // The pictures that answer "which policy, and why did jobs miss" open the page.
    std::vector<PlotFile> rest;
    for (const PlotFile& p : page.plots)
      (p.name == "metrics_bars" || p.name == "miss_over_time" ? page.lead_plots : rest)
          .push_back(p);
    page.plots = rest;
    if (timelines) page.lead_sections.push_back(timelines->section);
    std::vector<std::string> names;
    std::vector<std::vector<PhaseMetrics>> phases;
    for (const PageRun& run : in.runs) {
      names.push_back(run.metrics->name);
      phases.push_back(run.phases != nullptr ? *run.phases : std::vector<PhaseMetrics>{});
    }
    page.sections.push_back(why_section(s, names, phases));
    if (auto c = costs_section(metrics)) page.sections.push_back(std::move(*c));
    page.sections.push_back(phase_section(s, names, phases));
    if (auto e = write_file(dir, "index.html", render_html(page)))
      r.errors.push_back(*e);
    else
      wrote("index.html");
  }
  return r;
}

PageInput SavedRun::input() const {
  PageInput in;
  in.header = header;
  in.scenario = &scenario;
  for (std::size_t i = 0; i < metrics.size(); ++i)
    in.runs.push_back({&metrics[i], &jobs[i], &units[i], &phases[i],
                       has_waits[i] ? &waits[i] : nullptr, waits_cut[i], ends[i]});
  in.verdicts = verdicts;
  in.prediction = prediction;
  in.data_files = data_files;
  in.index_html = index_html;
  return in;
}

namespace {

Expected<ojson> read_json(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return Error{path, 0, "cannot open for reading (is this a run's output directory?)"};
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string text = ss.str();
  try {
    return ojson::parse(text);
  } catch (const ojson::parse_error& e) {
    // The byte offset of the error, as a line.
    const auto at = std::min<std::size_t>(e.byte, text.size());
    const int line = 1 + static_cast<int>(std::count(
                             text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
    return Error{path, line, "not valid JSON"};
  }
}

// The line of `"key"` in `path`'s text (1-based), or 0; for messages about a value.
int line_of(const std::string& path, const std::string& key) {
  std::ifstream f(path, std::ios::binary);
  std::string line;
  for (int n = 1; std::getline(f, line); ++n)
    if (line.find("\"" + key + "\"") != std::string::npos) return n;
  return 0;
}

PolicyMetrics metrics_from(const ojson& p) {
  PolicyMetrics m;
  m.name = p.at("name").get<std::string>();
  m.jobs = p.at("jobs").get<std::int64_t>();
  m.completed = p.at("completed").get<std::int64_t>();
  m.missed = p.at("missed").get<std::int64_t>();
  m.dropped = p.at("dropped").get<std::int64_t>();
  m.skipped = p.at("skipped").get<std::int64_t>();
  m.failed = p.at("failed").get<std::int64_t>();
  m.unfinished = p.at("unfinished").get<std::int64_t>();
  m.miss_rate = p.at("miss_rate").get<double>();
  m.drop_rate = p.at("drop_rate").get<double>();
  m.qoe = p.at("qoe").get<double>();
  m.on_time = p.at("on_time").get<double>();
  const auto& l = p.at("latency_ms");
  m.latency.mean = l.at("mean").get<double>();
  m.latency.p50 = l.at("p50").get<double>();
  m.latency.p90 = l.at("p90").get<double>();
  m.latency.p99 = l.at("p99").get<double>();
  m.latency.max = l.at("max").get<double>();
  m.encoder_runs = p.at("encoder_runs").get<std::int64_t>();
  m.encoder_runs_saved = p.at("encoder_runs_saved").get<std::int64_t>();
  m.measured_s = p.at("measured_s").get<double>();
  auto opt = [](const ojson& v) {
    return v.is_null() ? std::optional<double>() : std::optional<double>(v.get<double>());
  };
  const auto& ra = p.at("ratios");
  m.ratio_miss = opt(ra.at("miss_rate"));
  m.ratio_latency = opt(ra.at("latency_mean"));
  m.ratio_qoe = opt(ra.at("qoe"));
  if (p.contains("frames")) {
    const auto& f = p.at("frames");
    PolicyMetrics::Releases x;
    x.offered = f.at("offered").get<std::int64_t>();
    x.released = f.at("released").get<std::int64_t>();
    x.behind = f.at("behind_a_period").get<std::int64_t>();
    x.late_p50_ms = f.at("released_late_ms").at("p50").get<double>();
    x.late_p99_ms = f.at("released_late_ms").at("p99").get<double>();
    x.late_max_ms = f.at("released_late_ms").at("max").get<double>();
    m.releases = x;
  }
  if (p.contains("costs")) {  // a real run's, or one that followed --costs (docs/REPORTS.md)
    const auto& c = p.at("costs");
    m.online_costs = c.at("online").get<bool>();
    m.plan_changes = c.at("plan_changes").get<int>();
    const auto ms = [](const ojson& v) {
      return Duration{static_cast<std::int64_t>(std::llround(v.get<double>() * 1e6))};
    };
    for (const auto& u : c.at("units")) {
      UnitCostFigures f;
      f.unit = u.at("unit").get<std::string>();
      f.batch = u.at("batch").get<int>();
      f.runs = u.at("runs").get<int>();
      f.profile_mean = ms(u.at("profile_mean_ms"));
      f.run_mean = ms(u.at("run_mean_ms"));
      f.run_p50 = ms(u.at("run_p50_ms"));
      f.factor = u.at("planned_factor").get<double>();
      m.costs.push_back(f);
    }
  }
  return m;
}

PhaseFigures figures_from(const ojson& f) {
  PhaseFigures x;
  x.jobs = f.at("jobs").get<std::int64_t>();
  x.completed = f.at("completed").get<std::int64_t>();
  x.missed = f.at("missed").get<std::int64_t>();
  x.dropped = f.at("dropped").get<std::int64_t>();
  x.unfinished = f.at("unfinished").get<std::int64_t>();
  x.miss_rate = f.at("miss_rate").get<double>();
  x.drop_rate = f.at("drop_rate").get<double>();
  x.qoe = f.at("qoe").get<double>();
  x.latency_p50_ms = f.at("latency_ms").at("p50").get<double>();
  x.latency_p99_ms = f.at("latency_ms").at("p99").get<double>();
  if (f.contains("causes"))  // written since the causes were (an older summary has none)
    for (const auto& c : f.at("causes"))
      x.causes[c.at("cause").get<std::string>()] = c.at("jobs").get<std::int64_t>();
  return x;
}

// Merge waits and where the trace stops, per policy, from trace.json.
std::optional<Error> read_waits(const std::string& path, SavedRun& run) {
  auto doc = read_json(path);
  if (!doc) return doc.error();
  if (!doc->is_object() || !doc->contains("traceEvents") || !(*doc)["traceEvents"].is_array())
    return Error{path, 1, "not a trace of red (no traceEvents array)"};
  std::map<std::int64_t, std::size_t> policy_of_pid;
  const auto& events = (*doc)["traceEvents"];
  for (const auto& e : events)
    if (e.value("ph", "") == "M" && e.value("name", "") == "process_name") {
      const std::string name = e.at("args").value("name", "");
      for (std::size_t i = 0; i < run.metrics.size(); ++i)
        if (name == "policy " + run.metrics[i].name) {
          policy_of_pid[e.at("pid").get<std::int64_t>()] = i;
          run.has_waits[i] = true;  // recorded, even when there were none
        }
    }
  auto ts = [](const ojson& v) {
    return TimePoint{static_cast<std::int64_t>(std::llround(v.get<double>() * 1000.0))};
  };
  for (const auto& e : events) {
    const std::string name = e.value("name", "");
    if (name != "merge wait" && name != "trace truncated") continue;
    // Instants only: the counter of waiting tasks is a "C" event of the same name (its args
    // hold a count, not a wait).
    if (e.value("ph", "") == "C") continue;
    const auto it = policy_of_pid.find(e.value("pid", std::int64_t{-1}));
    if (it == policy_of_pid.end()) continue;
    const std::size_t i = it->second;
    if (name == "trace truncated") {
      run.waits_cut[i] = ts(e.at("ts"));
      continue;
    }
    TimelineWait w;
    w.at = ts(e.at("ts"));
    w.until = from_ms(e.at("args").at("until_ms").get<double>());
    const std::string sensor = e.at("args").value("sensor", "");
    for (std::size_t k = 0; k < run.scenario.sensors.size(); ++k)
      if (run.scenario.sensors[k].name == sensor) w.sensor = static_cast<int>(k);
    run.waits[i].push_back(w);
  }
  return std::nullopt;
}

// Whether the run's manifest lists file `f`.
bool lists(const SavedRun& run, const std::string& f) {
  return std::find(run.files.begin(), run.files.end(), f) != run.files.end();
}

// manifest.json: the run is complete, its command and files, and it lists the files red report
// reads.
std::optional<Error> read_manifest(const std::string& dir, SavedRun& run) {
  const std::string manifest = (fs::path(dir) / kManifestName).string();
  auto man = read_json(manifest);
  if (!man)
    return Error{
        man.error().file, man.error().line,
        man.error().message + " (every run of red compare and red run writes manifest.json last)"};
  try {
    if (!man->value("complete", false))
      return Error{manifest, line_of(manifest, "complete"),
                   "the run is not complete (\"complete\": false): it was stopped or a file "
                   "could not be written; run it again"};
    run.command = man->value("command", "");
    for (const auto& f : man->at("files")) run.files.push_back(f.at("path").get<std::string>());
  } catch (const nlohmann::json::exception& e) {
    return Error{manifest, 0, std::string("not a manifest of red: ") + e.what()};
  }
  for (const std::string& f : run.files)
    if (f.rfind("plots/", 0) != 0 && f != "index.html") run.data_files.push_back(f);
  for (const char* f : {"summary.json", "jobs.csv", "units.csv"})
    if (!lists(run, f))
      return Error{manifest, 0, std::string("does not list ") + f + ", which red report reads"};
  return std::nullopt;
}

// The scenario as summary.json's "page" keeps it (all the page uses): names, warm-up, duration,
// criticality, heads, lanes, sensors and events. Throws what nlohmann::json throws on a missing
// field.
std::optional<Error> scenario_from_page(const ojson& pg, const std::string& summary,
                                        SavedRun& run) {
  Scenario& s = run.scenario;
  s.name = run.header.scenario;
  s.duration = Duration{pg.at("duration_ns").get<std::int64_t>()};
  s.warmup = Duration{pg.at("warmup_ns").get<std::int64_t>()};
  s.names_ = pg.at("operations").get<std::vector<std::string>>();
  s.initial.resize(s.names_.size());
  // Definitions that carry only the criticality (all the causes read of them); a page
  // written before it was kept has none: every operation then counts as criticality 0.
  auto with_criticality = [](const std::string& name, int c) {
    auto op = std::make_shared<OperationSpec>();
    op->name = name;
    op->criticality = c;
    return std::shared_ptr<const OperationSpec>(std::move(op));
  };
  if (pg.contains("criticality")) {
    const auto& crit = pg.at("criticality");
    for (std::size_t i = 0; i < s.initial.size() && i < crit.size(); ++i)
      if (!crit[i].is_null()) s.initial[i] = with_criticality(s.names_[i], crit[i].get<int>());
  }
  s.model.heads = pg.at("heads").get<std::vector<std::string>>();
  s.device.lanes = pg.at("lanes").get<int>();
  for (const auto& x : pg.at("sensors")) {
    SensorSpec sensor;
    sensor.name = x.get<std::string>();
    s.sensors.push_back(std::move(sensor));
  }
  for (const auto& e : pg.at("events")) {
    EventSpec ev;
    ev.at = Duration{e.at("at_ns").get<std::int64_t>()};
    ev.kind = e.at("kind").get<std::string>();
    if (e.contains("criticality"))
      for (const auto& c : e.at("criticality")) {
        const auto op = c.at(0).get<int>();
        if (op < 0 || static_cast<std::size_t>(op) >= s.names_.size())
          return Error{
              summary, line_of(summary, "criticality"),
              fmt::format("an event changes operation {}, which \"operations\" lacks", op)};
        ev.changes.emplace_back(
            op, with_criticality(s.names_[static_cast<std::size_t>(op)], c.at(1).get<int>()));
      }
    s.events.push_back(std::move(ev));
  }
  return std::nullopt;
}

// Each policy's figures (summary.json's "policies"), its run's end and its figures per phase.
// Throws what nlohmann::json throws on a missing field.
std::optional<Error> policies_from(const ojson& sj, const ojson& pg, const std::string& summary,
                                   SavedRun& run) {
  const auto& pols = sj.at("policies");
  const auto& ends = pg.at("runs");
  if (ends.size() != pols.size())
    return Error{
        summary, line_of(summary, "runs"),
        fmt::format("\"page\" lists {} runs and \"policies\" {}", ends.size(), pols.size())};
  for (std::size_t i = 0; i < pols.size(); ++i) {
    run.metrics.push_back(metrics_from(pols[i]));
    run.ends.push_back(TimePoint{ends[i].at("end_ns").get<std::int64_t>()});
    std::vector<PhaseMetrics> phases;
    if (pols[i].contains("phases") && !pols[i]["phases"].empty()) {
      const auto spans = workload_phases(run.scenario, run.ends.back());
      const auto& ph = pols[i]["phases"];
      if (ph.size() != spans.size())
        return Error{summary, line_of(summary, "phases"),
                     fmt::format("policy {}: {} phases, the events give {}",
                                 run.metrics.back().name, ph.size(), spans.size())};
      for (std::size_t k = 0; k < spans.size(); ++k) {
        PhaseMetrics m;
        m.span = spans[k];
        m.all = figures_from(ph[k]);
        for (const auto& [name, f] : ph[k].at("operations").items())
          m.operations.emplace_back(name, figures_from(f));
        phases.push_back(std::move(m));
      }
    }
    run.phases.push_back(std::move(phases));
  }
  return std::nullopt;
}

// summary.json: the header, the page's scenario and tables, and each policy's figures.
std::optional<Error> read_summary(const std::string& dir, SavedRun& run) {
  const std::string summary = (fs::path(dir) / "summary.json").string();
  auto sj = read_json(summary);
  if (!sj) return sj.error();
  std::string key;  // the key being read, for the error's line
  try {
    key = "page";
    if (!sj->contains("page"))
      return Error{summary, 1,
                   "has no \"page\" object: written by an older red, whose page cannot be "
                   "redrawn from its files; run the comparison again to get one"};
    const auto& pg = sj->at("page");
    key = "scenario";
    run.header.scenario = sj->at("scenario").get<std::string>();
    run.header.backend = sj->at("backend").get<std::string>();
    run.header.baseline = sj->at("baseline").get<std::string>();
    run.header.seed = sj->at("seed").get<std::uint64_t>();
    run.header.profile_source = sj->at("profile").get<std::string>();
    run.header.run_id = sj->value("run_id", "");
    key = "page";
    if (auto e = scenario_from_page(pg, summary, run)) return e;
    run.index_html = pg.at("index_html").get<bool>();
    if (!pg.at("verdicts").is_null()) run.verdicts = table_from(pg.at("verdicts"));
    for (const auto& t : pg.at("prediction")) run.prediction.push_back(table_from(t));
    key = "policies";
    if (auto e = policies_from(*sj, pg, summary, run)) return e;
  } catch (const nlohmann::json::exception& e) {
    return Error{
        summary, line_of(summary, key),
        std::string("a field red report needs is missing or of the wrong type: ") + e.what()};
  }
  return std::nullopt;
}

// jobs.csv and units.csv, each row to the policy of summary.json it names.
std::optional<Error> read_rows(const std::string& dir, SavedRun& run) {
  const std::size_t n = run.metrics.size();
  auto index_of = [&](const std::string& policy) -> std::optional<std::size_t> {
    for (std::size_t i = 0; i < n; ++i)
      if (run.metrics[i].name == policy) return i;
    return std::nullopt;
  };
  const std::string jobs_path = (fs::path(dir) / "jobs.csv").string();
  auto jobs = read_job_rows(jobs_path, run.scenario);
  if (!jobs) return jobs.error();
  for (auto& [policy, rows] : *jobs) {
    const auto i = index_of(policy);
    if (!i) return Error{jobs_path, 0, "rows of policy '" + policy + "', which summary.json lacks"};
    run.jobs[*i] = std::move(rows);
  }
  const std::string units_path = (fs::path(dir) / "units.csv").string();
  auto units = read_unit_rows(units_path, run.scenario);
  if (!units) return units.error();
  for (auto& [policy, rows] : *units) {
    const auto i = index_of(policy);
    if (!i)
      return Error{units_path, 0, "rows of policy '" + policy + "', which summary.json lacks"};
    run.units[*i] = std::move(rows);
  }
  return std::nullopt;
}

}  // namespace

Expected<SavedRun> read_saved_run(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return Error{dir, 0, "no such directory"};
  SavedRun run;
  if (auto e = read_manifest(dir, run)) return *e;
  if (auto e = read_summary(dir, run)) return *e;
  const std::size_t n = run.metrics.size();
  run.jobs.resize(n);
  run.units.resize(n);
  run.waits.resize(n);
  run.has_waits.assign(n, false);
  run.waits_cut.resize(n);
  if (auto e = read_rows(dir, run)) return *e;
  if (lists(run, "trace.json"))
    if (auto e = read_waits((fs::path(dir) / "trace.json").string(), run)) return *e;
  return run;
}

}  // namespace red
