/// \file
/// `red node` and `red camera` (docs/ROS2.md): RED as a ROS 2-compatible node on Cyclone DDS, and a
/// camera publisher for demos and tests. Built only with the DDS bridge (RED_HAVE_DDS).

#include <fmt/format.h>
#include <malloc.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <string_view>
#include <thread>
#include <vector>

#include "commands.hpp"
#include "common.hpp"
#include "real_run.hpp"
#include "red/dds/camera.hpp"
#include "red/dds/node.hpp"
#include "red/dds/security.hpp"
#include "red/metrics/metrics.hpp"
#include "red/report/report.hpp"
#include "red/report/row_queue.hpp"
#include "red/report/stream.hpp"
#include "red/sched/policy.hpp"
#include "signals.hpp"

namespace red::cli {

namespace {

struct DdsArgs {
  int domain = 0;
  std::string config;   // file with Cyclone DDS XML
  bool shm = false;     // through iceoryx shared memory
  std::string enclave;  // --security-enclave: DDS Security with this SROS2 enclave
};

void add_dds(CLI::App* cmd, DdsArgs& a) {
  cmd->add_option("--domain", a.domain, "DDS domain id (ROS_DOMAIN_ID), 0..232")
      ->check(CLI::Range(0, 232))
      ->capture_default_str();
  cmd->add_option("--config", a.config,
                  "Cyclone DDS XML configuration file (default: loopback only, see docs/ROS2.md)");
  cmd->add_flag("--shm", a.shm,
                "Exchange samples with this host's other processes through shared memory "
                "(iceoryx; needs a running iox-roudi, see docs/ROS2.md)");
  cmd->add_option("--security-enclave", a.enclave,
                  "DDS Security (SROS2) with this enclave of $ROS_SECURITY_KEYSTORE, e.g. "
                  "/red/node (ROS_SECURITY_ENCLAVE_OVERRIDE wins; see docs/ROS2.md, \"Security\")");
}

// With --shm, keep the pages of large buffers: each frame's pixel buffer (921 KB for 640x480
// rgb8) is allocated when the node takes the sample from shared memory and freed once
// converted, and glibc's dynamic mmap and trim thresholds returned and faulted those pages
// in again in about half the runs (~150 page faults a frame, transport p50 ~1.0 ms instead of
// ~0.5 ms; docs/journal/ros2-node.md, "Shared memory (iceoryx)"). Large blocks come from the heap,
// which is not trimmed below 128 MiB of free space.
void keep_large_buffers() {
  (void)mallopt(M_MMAP_THRESHOLD, 32 << 20);  // glibc's largest (64-bit)
  (void)mallopt(M_TRIM_THRESHOLD, 128 << 20);
}

// With --shm, RouDi must run: iceoryx would wait for it and then abort the process. Exit 2
// (bad input) with how to start it, before anything else is opened.
bool roudi_ok(const DdsArgs& a) {
  if (!a.shm) return true;
  auto up = dds::roudi_running();
  if (!up) print_error(up.error());
  return up.has_value();
}

// The configuration text of --config, or empty for the loopback default.
Expected<std::string> read_config(const std::string& path) {
  if (path.empty()) return std::string{};
  std::ifstream f(path);
  if (!f) return Error{path, 0, "cannot open the Cyclone DDS configuration file"};
  std::stringstream ss;
  ss << f.rdbuf();
  if (ss.str().find('<') == std::string::npos)
    return Error{path, 0, "not a Cyclone DDS XML configuration (no XML element)"};
  return ss.str();
}

struct NodeArgs {
  ScenarioArgs scenario;
  DdsArgs dds;
  std::string policy = dds::kDefaultNodePolicy;
  std::string qos_file;
  std::vector<std::string> remaps;
  double duration_s = 0;
  std::string backend;
  RealRunOptions real;
  bool realtime = false;
  std::optional<std::string> out;
};

// DDS Security from ROS 2's environment and --security-enclave (docs/ROS2.md, "Security"):
// the enclave to use, or none; false (after printing why) when the process must not start:
// Enforce without a usable enclave, a bad variable. Permissive without one warns.
bool resolve_enclave(const DdsArgs& a, const char* who, std::optional<dds::Enclave>& enclave) {
  auto s = dds::resolve_security(dds::SecurityEnv::from_environment(), a.enclave);
  if (!s) {
    print_error(s.error());
    return false;
  }
  if (!s->warning.empty()) std::cerr << who << ": warning: " << s->warning << '\n';
  enclave = s->enclave;
  return true;
}

// Step 1 of `red node`: the scenario, its profile and the node's options from the command
// line, the environment and the files it names. Prints the first problem; false: exit 2.
struct NodeSetup {
  std::optional<LoadedScenario> loaded;
  dds::NodeOptions o;
};
bool parse_node(const NodeArgs& a, NodeSetup& n) {
  n.loaded = load_with_profile(a.scenario);
  if (!n.loaded) return false;
  if (!make_policy(a.policy)) {
    print_error(Error{"", 0, unknown_policy_message(a.policy)});
    return false;
  }
  if (!resolve_enclave(a.dds, "red node", n.o.security) || !roudi_ok(a.dds)) return false;
  dds::NodeOptions& o = n.o;
  o.policy = a.policy;
  o.domain = a.dds.domain;
  o.shared_memory = a.dds.shm;
  o.realtime = a.realtime;
  o.watchdog_x = a.real.watchdog_x;
  if (a.duration_s > 0) o.duration = Duration{static_cast<std::int64_t>(a.duration_s * 1e9)};
  auto config = read_config(a.dds.config);
  if (!config) {
    print_error(config.error());
    return false;
  }
  o.config = *config;
  if (!a.qos_file.empty()) {
    auto q = dds::load_qos_file(a.qos_file);
    if (!q) {
      print_error(q.error());
      return false;
    }
    o.qos = *q;
  }
  for (const std::string& r : a.remaps)
    if (auto ok = o.remaps.add(r); !ok) {
      print_error(ok.error());
      return false;
    }
  return true;
}

// What the node prints when it starts: where it listens, what it publishes.
void print_node_start(const NodeArgs& a, const Scenario& s, const dds::NodeOptions& o,
                      const dds::Node& node, std::string_view backend) {
  const dds::NodeTopics& t = node.topics();
  std::cerr << fmt::format(
      "red node: {} on DDS domain {} ({}{}{}), policy {}, backend {}\n", s.name, o.domain,
      o.config.empty() ? "loopback only" : a.dds.config, o.shared_memory ? ", shared memory" : "",
      o.security ? ", DDS Security with enclave " + o.security->name : "", a.policy, backend);
  for (std::size_t i = 0; i < t.sensors.size(); ++i)
    std::cerr << fmt::format("red node:   in  {} (sensor {}, sensor_msgs/msg/Image)\n",
                             t.sensors[i], s.sensors[i].name);
  for (const auto& [key, topic] : t.nodes) {
    const int head = t.heads.at(key);
    if (head < 0) continue;
    const auto kind = dds::output_kind(s.model.heads[static_cast<std::size_t>(head)]);
    std::cerr << fmt::format("red node:   out {} ({})\n", topic,
                             kind == dds::OutputKind::Velocity
                                 ? "geometry_msgs/msg/Twist, and TwistStamped on <topic>/stamped"
                             : kind == dds::OutputKind::Detections
                                 ? "vision_msgs/msg/Detection2DArray"
                                 : "sensor_msgs/msg/Image mono8");
  }
  std::cerr << fmt::format("red node:   out {} (diagnostic_msgs/msg/DiagnosticArray)\n",
                           t.diagnostics);
}

// Counters split into what the node refused (rejected) and what DDS never delivered.
struct NotTaken {
  std::uint64_t rejected = 0, undelivered = 0;
  std::string reasons, lost;
};
NotTaken not_taken(const dds::NodeCounters& c) {
  NotTaken n;
  for (int r = 0; r < dds::kRejectKinds; ++r) {
    const auto why = static_cast<dds::Reject>(r);
    const std::uint64_t count = c.rejected[static_cast<std::size_t>(r)];
    const bool transport = why == dds::Reject::LostInTransport || why == dds::Reject::RejectedByDds;
    (transport ? n.undelivered : n.rejected) += count;
    if (count > 0)
      (transport ? n.lost : n.reasons) += fmt::format(" {} {}", dds::to_string(why), count);
  }
  return n;
}

// The run's summary on stderr: counters and where a frame's time went.
void print_node_end(const std::string& policy, const std::optional<dds::Enclave>& security,
                    const dds::Node& node, const RuntimeReport& report) {
  const dds::NodeCounters c = node.counters();
  const NotTaken n = not_taken(c);
  std::cerr << fmt::format(
      "red node: {} frames ({} released), {} rejected{}; {} not delivered by DDS{}; published {} "
      "masks, {} twists, {} detection arrays, {} diagnostics; {} jobs without output\n",
      c.frames, c.released, n.rejected, n.reasons, n.undelivered, n.lost, c.masks, c.twists,
      c.detections, c.diagnostics, c.jobs_without_output);
  if (security)
    std::cerr << fmt::format(
        "red node: DDS Security (enclave {}) refused {} participant(s) and {} endpoint(s), as "
        "Cyclone DDS's log and discovery trace report them\n",
        security->name, c.refused_participants, c.refused_endpoints);
  print_runtime_report(policy, report);
  const dds::Node::Timings tm = node.timings();
  const auto line = [](const char* what, const std::vector<double>& v, const std::string& tail) {
    std::cerr << fmt::format("red node: {} p50 {:.2f} us, p99 {:.2f} us{}\n", what,
                             percentile(v, 0.5), percentile(v, 0.99), tail);
  };
  line("frame stamp -> taken (camera to node over DDS)", tm.transport_us, "");
  line("job end -> output written", tm.publish_us,
       fmt::format(" ({} outputs)", tm.publish_us.size()));
  line("  of which queued -> the publishing thread woke", tm.publish_wake_us,
       fmt::format(" ({} waits)", tm.publish_wake_us.size()));
  line("frame taken -> pushed (check, move, keep; converted after the release)", tm.intake_us,
       fmt::format(" ({} frames)", tm.intake_us.size()));
  line("frame pushed -> released (runtime)", report.frame_release_us,
       fmt::format(" ({} frames)", report.frame_release_us.size()));
  // docs/ROS2.md's "frame received -> job released", frame by frame: taken from the reader ->
  // the job released, stamped by the node's observer when the runtime released it on the
  // receiving thread; for a frame posted to the global synchronizer, taken -> pushed plus
  // the runtime's pushed -> released.
  std::vector<double> taken_released;
  std::size_t direct = 0;
  for (std::size_t i = 0; i < tm.released_intake_us.size(); ++i) {
    const double d = i < tm.taken_released_us.size() ? tm.taken_released_us[i] : std::nan("");
    if (!std::isnan(d)) {
      taken_released.push_back(d);
      ++direct;
    } else if (i < report.frame_release_us.size()) {
      taken_released.push_back(tm.released_intake_us[i] + report.frame_release_us[i]);
    }
  }
  line("frame taken -> job released", taken_released,
       fmt::format(" ({} frames, {} released on the receiving thread)", taken_released.size(),
                   direct));
  line(
      "job released -> push returned (the runtime's round after the release, on the receiving "
      "thread)",
      tm.after_release_us, fmt::format(" ({} frames)", tm.after_release_us.size()));
}

// node.json: what the node took and could not take, by reason (summary.json holds the jobs).
nlohmann::json node_json(const std::string& run_id, const dds::NodeCounters& c,
                         const std::optional<dds::Enclave>& security) {
  const NotTaken n = not_taken(c);
  nlohmann::json nj{{"run_id", run_id},
                    {"frames", c.frames},
                    {"released", c.released},
                    {"not_taken", n.rejected + n.undelivered},
                    {"published",
                     {{"masks", c.masks},
                      {"twists", c.twists},
                      {"detections", c.detections},
                      {"diagnostics", c.diagnostics}}},
                    {"jobs_without_output", c.jobs_without_output}};
  nlohmann::json by_reason = nlohmann::json::object();
  for (int r = 0; r < dds::kRejectKinds; ++r)
    by_reason[dds::to_string(static_cast<dds::Reject>(r))] =
        c.rejected[static_cast<std::size_t>(r)];
  nj["not_taken_by_reason"] = std::move(by_reason);
  // What DDS Security refused, from Cyclone's log and discovery trace (docs/ROS2.md,
  // "Security").
  nj["security"] = security ? nlohmann::json{{"enclave", security->name},
                                             {"refused_participants", c.refused_participants},
                                             {"refused_endpoints", c.refused_endpoints}}
                            : nlohmann::json{{"enclave", nullptr}};
  return nj;
}

// The output directory of a node run (--out): opened before the run, the rows streamed to
// it during the run, summary.json, node.json and the manifest written at the end.
struct NodeOutput {
  std::unique_ptr<CsvRowStream> stream;
  std::optional<RowQueue> queue;
  std::optional<OutputSet> set;  // the run's files, ended by manifest.json (docs/REPORTS.md)
};

// Step 2: the backend, the node, the metrics and the output directory.
struct NodeParts {
  std::unique_ptr<Backend> backend;
  std::unique_ptr<dds::Node> node;
  std::unique_ptr<MetricsCollector> metrics;
  NodeOutput out;
};
int build_node(const NodeArgs& a, NodeSetup& n, NodeParts& parts) {
  const Scenario& s = n.loaded->scenario;
  const Profile& p = n.loaded->profile;
  RealRunOptions real = a.real;
  real.backend = a.backend;
  real.seed = s.seed;
  auto backend = make_backend(s, p, real);
  if (!backend) {
    print_error(backend.error());
    return kBadInput;
  }
  parts.backend = std::move(*backend);
  if (auto note = profile_origin_note(s, p, real)) std::cerr << "red: note: " << *note << '\n';
  auto node = dds::Node::make(s, p, *parts.backend, n.o);
  if (!node) {
    print_error(node.error());
    return kRunFailure;
  }
  parts.node = std::move(*node);
  parts.metrics = std::make_unique<MetricsCollector>(s, s.scheduler.qoe_lambda, a.out.has_value());
  // A node runs for the life of a robot: its rows go to jobs.csv and units.csv as jobs end
  // (with --out), never into memory; the summary keeps bounded state (docs/REPORTS.md).
  parts.metrics->set_keep_rows(false);
  if (a.out) {
    auto begun = OutputSet::begin(*a.out, "node");
    if (!begun) {
      print_error(begun.error());
      return kRunFailure;
    }
    parts.out.set = std::move(begun.value());
    auto st = CsvRowStream::open(*a.out, s, true);
    if (!st) {
      print_error(st.error());
      return kRunFailure;
    }
    parts.out.stream = std::move(st.value());
    parts.out.stream->begin_policy(a.policy);
    // Rows are formatted and written on the queue's thread, off the hand-off (row_queue.hpp).
    parts.out.queue.emplace(*parts.out.stream);
    parts.metrics->set_sink(&*parts.out.queue);
  }
  parts.node->add_observer(parts.metrics.get());
  return kOk;
}

// Step 4 (with --out): summary.json, jobs.csv, units.csv, node.json and the manifest.
int write_node(const NodeArgs& a, const NodeSetup& setup, NodeParts& parts,
               const RuntimeReport& report, PolicyMetrics costs, double wall_s) {
  const LoadedScenario& l = *setup.loaded;
  const Scenario& s = l.scenario;
  NodeOutput& out = parts.out;
  PolicyRun run;
  run.wall_s = wall_s;
  run.metrics = parts.metrics->summarize(a.policy, report.end);
  run.metrics.decision_p50_us = percentile(report.decision_us, 0.5);
  run.metrics.decision_p99_us = percentile(report.decision_us, 0.99);
  run.metrics.online_costs = costs.online_costs;
  run.metrics.plan_changes = costs.plan_changes;
  run.metrics.costs = std::move(costs.costs);
  run.result.end = report.end;
  run.result.stats = report.stats;
  out.queue->drain();
  const std::optional<Error> flushed = out.stream->flush();
  auto rows = flushed ? Expected<std::vector<StreamedRows>>(*flushed) : out.stream->rows();
  if (!rows) {
    print_error(rows.error());
    return kRunFailure;
  }
  if (!rows->empty()) {
    run.jobs = std::move(rows->front().jobs);
    run.units = std::move(rows->front().units);
  }
  if (auto e = out.stream->finish()) {
    print_error(*e);
    return kRunFailure;
  }
  OutputOptions oo;
  oo.gnuplot = "none";
  oo.rows_written = true;
  oo.rows_files = out.stream->finished();
  oo.set = &*out.set;
  OutputReport wrote;
  std::vector<PolicyRun> runs{std::move(run)};
  if (auto e = write_outputs(*a.out, s, l.profile, std::string(parts.backend->name()), s.seed, runs,
                             oo, &wrote)) {
    for (const Error& f : wrote.errors) print_error(f);
    return kRunFailure;
  }
  const nlohmann::json nj = node_json(out.set->run_id(), parts.node->counters(), setup.o.security);
  const std::optional<Error> failed = write_file(*a.out, "node.json", nj.dump(2) + "\n");
  if (failed) {
    print_error(*failed);
    out.set->fail(*failed);
  } else {
    out.set->add("node.json");
  }
  if (auto e = out.set->finish()) {
    print_error(*e);
    return kRunFailure;
  }
  if (failed) return kRunFailure;
  std::cerr << "red node: " << wrote_message(*a.out, wrote) << ", node.json\n";
  return kOk;
}

// `red node`: parse -> build -> run -> write.
int run_node(const NodeArgs& a) {
  NodeSetup setup;
  if (!parse_node(a, setup)) return kBadInput;
  if (a.dds.shm) keep_large_buffers();
  NodeParts parts;
  if (const int code = build_node(a, setup, parts); code != kOk) return code;
  print_node_start(a, setup.loaded->scenario, setup.o, *parts.node, parts.backend->name());
  // SIGINT/SIGTERM end a node as --duration does (releases end, jobs in flight drain): the
  // normal way to stop a node, so it exits 0 (signals.hpp).
  install_stop_signals();
  dds::Node* n = parts.node.get();
  std::optional<StopWatch> watch;
  watch.emplace([n] { n->stop(); });
  const auto t0 = std::chrono::steady_clock::now();
  RuntimeReport report = parts.node->run();
  watch.reset();
  print_node_end(a.policy, setup.o.security, *parts.node, report);
  // What the node's units cost against the profile (docs/DESIGN.md, "Online costs").
  PolicyMetrics costs;
  costs.online_costs = report.online_costs;
  costs.plan_changes = report.plan_changes;
  costs.costs = report.costs;
  if (auto w = costs_differed(costs, a.policy)) std::cerr << "red node: " << *w << '\n';
  if (a.out) {
    const double wall_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (const int code = write_node(a, setup, parts, report, std::move(costs), wall_s); code != kOk)
      return code;
  }
  if (!report.device_lost.empty()) {
    print_error(Error{"", 0, report.device_lost + "; the run stopped there (docs/GPU.md)"});
    return kRunFailure;
  }
  return kOk;
}

struct CameraArgs {
  DdsArgs dds;
  std::string qos_file;
  dds::CameraOptions o;
  std::string size = "640x480";
  std::uint64_t count = 0;
  double duration_s = 0;
};

int run_camera(CameraArgs& a) {
  int w = 0, h = 0;
  char x = 0;
  std::istringstream ss(a.size);
  if (!(ss >> w >> x >> h) || x != 'x' || !ss.eof()) {
    print_error(Error{"", 0, "--size '" + a.size + "': expected WxH, e.g. 640x480"});
    return kBadInput;
  }
  if (!resolve_enclave(a.dds, "red camera", a.o.security) || !roudi_ok(a.dds)) return kBadInput;
  a.o.width = w;
  a.o.height = h;
  a.o.domain = a.dds.domain;
  a.o.shared_memory = a.dds.shm;
  if (a.count > 0) a.o.count = a.count;
  if (a.duration_s > 0) a.o.duration = Duration{static_cast<std::int64_t>(a.duration_s * 1e9)};
  auto config = read_config(a.dds.config);
  if (!config) {
    print_error(config.error());
    return kBadInput;
  }
  a.o.config = *config;
  if (!a.qos_file.empty()) {  // the writer's QoS: the file's input: section (the node's readers)
    auto q = dds::load_qos_file(a.qos_file);
    if (!q) {
      print_error(q.error());
      return kBadInput;
    }
    a.o.qos = q->input;
  }
  // SIGINT/SIGTERM end the camera as --count does (exit 0).
  install_stop_signals();
  std::atomic<bool> stop{false};
  StopWatch watch([&stop] { stop.store(true); });
  auto r = dds::run_camera(a.o, stop);
  if (!r) {
    print_error(r.error());
    return kBadInput;
  }
  std::cerr << fmt::format("red camera: published {} frames on {}{}{}\n", r->published, a.o.topic,
                           r->skipped > 0 ? fmt::format(" ({} left out)", r->skipped) : "",
                           r->matched ? "" : " (no subscriber was matched before the first)");
  return kOk;
}

}  // namespace

void register_node(CLI::App& app, int& exit_code) {
  auto a = std::make_shared<NodeArgs>();
#ifdef RED_HAVE_TORCH
  a->backend = "torch";
#else
  a->backend = "synthetic";
#endif
  CLI::App* cmd = app.add_subcommand(
      "node", "RED as a ROS 2-compatible node on DDS: camera topics in, head outputs out");
  cmd->add_option("scenario", a->scenario.path, "Scenario file (YAML)")->required();
  cmd->add_option("--profile", a->scenario.profile, "Profile JSON (default: the scenario's)");
  cmd->add_option("--set", a->scenario.sets, "Override a scenario value: key=value");
  cmd->add_option("--policy", a->policy, "Policy preset")->capture_default_str();
  add_with_option(cmd, a->scenario);
  add_dds(cmd, a->dds);
  cmd->add_option("--qos-file", a->qos_file, "QoS overrides (YAML: input:/output:)");
  cmd->add_option("--remap", a->remaps, "Rename a topic, ROS 2 style: from:=to (repeatable)");
  cmd->add_option("--duration", a->duration_s,
                  "Stop releasing after this many seconds (default: until SIGINT/SIGTERM)")
      ->check(finite_positive());
  cmd->add_option("--backend", a->backend,
                  "torch (real inference) or synthetic (spends profiled unit times)")
      ->check(CLI::IsMember({"torch", "synthetic"}))
      ->capture_default_str();
  add_device_options(cmd, a->real);
  cmd->add_flag("--realtime", a->realtime, "Try SCHED_FIFO, CPU affinity and mlockall");
  cmd->add_option("--watchdog-x", a->real.watchdog_x,
                  "Fail a unit still running after this many times its profiled p99 with the "
                  "reason 'timeout' (0: no watchdog)")
      ->check(finite_non_negative())
      ->capture_default_str();
  cmd->add_option("--out", a->out, "Write summary.json, jobs.csv, units.csv here at the end");
  cmd->callback([a, &exit_code] { exit_code = run_node(*a); });
}

void register_camera(CLI::App& app, int& exit_code) {
  auto a = std::make_shared<CameraArgs>();
  CLI::App* cmd =
      app.add_subcommand("camera", "Publish synthetic camera frames (sensor_msgs/Image) on DDS");
  cmd->add_option("--rate", a->o.rate_hz, "Frames per second")->capture_default_str();
  cmd->add_option("--topic", a->o.topic, "ROS 2 topic")->capture_default_str();
  cmd->add_option("--size", a->size, "Frame size WxH")->capture_default_str();
  cmd->add_option("--encoding", a->o.encoding, "rgb8, bgr8 or mono8")->capture_default_str();
  cmd->add_option("--frame-id", a->o.frame_id, "header.frame_id")->capture_default_str();
  cmd->add_option("--from", a->o.from_dir,
                  "Publish the PNG/JPEG images of this directory (name order, looped; their own "
                  "size) instead of synthetic frames");
  cmd->add_option("--count", a->count, "Stop after this many frames (default: never)")
      ->check(CLI::Validator(
          [](std::string& text) {
            const bool digits =
                !text.empty() && text.find_first_not_of("0123456789") == std::string::npos;
            return digits && text.find_first_not_of('0') != std::string::npos
                       ? std::string()
                       : "must be a whole number >= 1, not '" + text + "'";
          },
          "COUNT >= 1"));
  cmd->add_option("--duration", a->duration_s, "Stop after this many seconds")
      ->check(finite_positive());
  cmd->add_option("--skip-every", a->o.skip_every,
                  "Leave out every N-th frame, as a lossy link would (tests what a subscriber "
                  "counts as lost)")
      ->check(whole_number());
  cmd->add_option("--stamps-topic", a->o.stamps_topic,
                  "Also publish each frame's header (std_msgs/msg/Header, reliable) here: a "
                  "probe counts frames without receiving their pixels");
  cmd->add_option("--qos-file", a->qos_file,
                  "QoS of the frames' writer: the input: section of a `red node --qos-file` "
                  "(e.g. reliable, to match a node that reads reliably)");
  add_dds(cmd, a->dds);
  cmd->callback([a, &exit_code] { exit_code = run_camera(*a); });
}

}  // namespace red::cli
