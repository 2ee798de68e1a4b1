/// \file
/// `red profile`: measures every unit of a model on the LibTorch backend (docs/DESIGN.md,
/// "Profiles"), prints a table with the shared-versus-separate comparison (docs/DESIGN.md,
/// "Performance targets") and writes the profile JSON. Without the LibTorch backend the command
/// exists but only says how to get it.

#include <algorithm>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "commands.hpp"
#include "red/core/output_file.hpp"

#if defined(RED_HAVE_TORCH)
#include <fmt/format.h>

#include <cerrno>
#include <charconv>
#include <cstdio>
#include <fstream>

#include "common.hpp"
#include "real_run.hpp"
#include "red/calibrate/calibrate.hpp"
#include "red/profile/profile.hpp"
#include "red/profile/quality.hpp"
#include "red/report/stream.hpp"
#include "red/torch/lane_device.hpp"
#include "red/torch/profiler.hpp"
#endif

namespace red::cli {

#if !defined(RED_HAVE_TORCH)

void register_profile(CLI::App& app, int& exit_code) {
  CLI::App* cmd =
      app.add_subcommand("profile", "Measure every unit on the LibTorch backend (docs/MODELS.md)");
  cmd->allow_extras();
  cmd->callback([&exit_code] {
    std::cerr << "red profile needs the LibTorch backend (build with -DRED_TORCH=ON)\n";
    exit_code = kRunFailure;
  });
}

#else

namespace {

struct ProfileArgs {
  std::string model = "builtin";
  std::string heads;
  std::string input = "3,192,384";
  /// cpu, cuda or cuda:N; unset: cpu, or with --from the device that profile was measured on
  std::optional<std::string> device;
  int threads = -1;  // -1: the CPUs not busy with other processes (default_profile_threads)
  int runs = torchb::ProfileOptions{}.runs;
  int warmup = torchb::ProfileOptions{}.warmup;
  int warmup_max = torchb::ProfileOptions{}.warmup_max;
  int max_batch = torchb::ProfileOptions{}.max_batch;
  int coarse_max_batch = torchb::ProfileOptions{}.coarse_max_batch;
  std::uint64_t seed = 1;
  bool no_separate = false;
  bool quiet = false;
  bool debug_sync = false;  ///< LibTorch's CUDA sync debug mode on warn
  std::string out;
  // Calibration (docs/FIDELITY.md): real runs of a scenario after the isolated profile.
  std::string from;                         ///< calibrate this profile instead of measuring one
  std::string calibrate;                    ///< scenario path; empty: no calibration
  std::vector<std::string> calibrate_sets;  ///< --set overrides of that scenario
  std::vector<std::string> calibrate_from;  ///< fit from these real runs' units.csv instead
  double calibrate_s = 8.0;                 ///< seconds per policy
  std::string calibrate_policies = "edf,red,mono";
  /// Turns per policy, each calibrate_s / rounds seconds; unset: 3, fewer below 3 s.
  std::optional<int> calibrate_rounds;
};

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  while (start <= s.size()) {
    std::size_t end = s.find(',', start);
    if (end == std::string::npos) end = s.size();
    parts.push_back(s.substr(start, end - start));
    start = end + 1;
  }
  return parts;
}

Expected<std::vector<std::int64_t> > parse_shape(const std::string& text) {
  const Error bad{"", 0, "--input: expected C,H,W such as 3,192,384, not '" + text + "'"};
  std::vector<std::int64_t> shape;
  for (const std::string& part : split(text)) {
    std::int64_t v = 0;
    const char* last = part.data() + part.size();
    auto [ptr, ec] = std::from_chars(part.data(), last, v);
    if (part.empty() || ec != std::errc{} || ptr != last || v <= 0) return bad;
    shape.push_back(v);
  }
  if (shape.size() != 3) return bad;
  return shape;
}

/// Builds the model and profile options, or an Error for bad arguments.
Expected<torchb::ModelOptions> model_options(const ProfileArgs& a) {
  torchb::ModelOptions m;
  if (a.model != "builtin") m.manifest = a.model;
  if (!a.heads.empty()) {
    m.heads = split(a.heads);
    for (const auto& h : m.heads) {
      if (h.empty()) return Error{"", 0, "--heads: empty head name in '" + a.heads + "'"};
    }
  }
  auto shape = parse_shape(a.input);
  if (!shape) return shape.error();
  m.input = *shape;
  m.device = a.device.value_or("cpu");
  if (a.threads < -1) return Error{"", 0, "--threads must be >= 0"};
  if (a.threads >= 0) {
    m.threads = a.threads;
  } else {
    // Not every hardware thread: on a machine already busy that oversubscribes the CPUs and
    // every unit waits for one (docs/journal/real-runs.md, "Default profile threads").
    const int online = online_cpus();
    const double busy = other_busy_cpus_now(0.5);
    m.threads = default_profile_threads(online, busy);
    if (!a.quiet)
      std::cerr << fmt::format(
          "red profile: --threads {} (of {} online CPU(s); {:.1f} busy with other processes)\n",
          m.threads, online, busy);
  }
  m.seed = a.seed;
  return m;
}

std::string mb(std::int64_t bytes) {
  return fmt::format("{:.1f} MB", static_cast<double>(bytes) / 1e6);
}

void print_table(const Profile& p, const std::vector<std::string>& heads) {
  fmt::print("profile of {} on {}\n\n", p.model, p.device);
  fmt::print("{:<18} {:>5} {:>9} {:>9} {:>9} {:>9} {:>9}\n", "unit", "batch", "mean ms", "p50 ms",
             "p95 ms", "p99 ms", "max ms");
  std::vector<std::string> order{"encoder"};
  for (const char* kind : {"head/", "coarse/", "separate/"}) {
    for (const auto& h : heads) order.push_back(kind + h);
  }
  for (const auto& name : order) {
    const UnitProfile* u = p.find(name);
    if (u == nullptr) continue;
    for (int b = 1; b <= u->max_batch(); ++b) {
      const LatencyStats& s = u->at(b);
      fmt::print("{:<18} {:>5} {:>9.3f} {:>9.3f} {:>9.3f} {:>9.3f} {:>9.3f}\n", name, b,
                 to_ms(s.mean), to_ms(s.p50), to_ms(s.p95), to_ms(s.p99), to_ms(s.max));
    }
  }

  fmt::print("\n{:<26} {:>12} {:>18} {:>12}\n", "memory", "parameters", "peak activations",
             "resident");
  auto memory_row = [](const char* label, const MemoryStats& m) {
    fmt::print("{:<26} {:>12} {:>18} {:>12}\n", label, mb(m.parameter_bytes),
               mb(m.peak_activation_bytes), mb(m.resident_bytes));
  };
  if (p.shared_memory) memory_row("shared (one encoder)", *p.shared_memory);
  if (p.separate_memory) memory_row("separate (one per head)", *p.separate_memory);

  // One frame through every head at batch 1: the shared encoder once plus each head,
  // against every separate network (docs/DESIGN.md, "Performance targets": ≥ 2.5x faster, ≤ 0.5x
  // memory).
  const UnitProfile* enc = p.find("encoder");
  Duration shared{0};
  Duration separate{0};
  bool have_separate = enc != nullptr;
  if (enc != nullptr) shared += enc->at(1).mean;
  for (const auto& h : heads) {
    if (const UnitProfile* u = p.find("head/" + h)) shared += u->at(1).mean;
    const UnitProfile* s = p.find("separate/" + h);
    if (s == nullptr) {
      have_separate = false;
    } else {
      separate += s->at(1).mean;
    }
  }
  fmt::print("\none frame through all {} heads (batch 1, mean):\n", heads.size());
  if (enc != nullptr) {
    fmt::print("  shared   {:>9.3f} ms (encoder {:.0f} % of it)\n", to_ms(shared),
               100.0 * to_ms(enc->at(1).mean) / to_ms(shared));
  }
  if (have_separate && shared.count() > 0) {
    fmt::print("  separate {:>9.3f} ms (separate / shared = {:.2f}x)\n", to_ms(separate),
               to_ms(separate) / to_ms(shared));
  }
  if (p.shared_memory && p.separate_memory) {
    const auto model_bytes = [](const MemoryStats& m) {
      return static_cast<double>(m.parameter_bytes + m.peak_activation_bytes);
    };
    const double sep = model_bytes(*p.separate_memory);
    if (sep > 0) {
      fmt::print(
          "  memory (parameters + peak activations): shared {} vs separate {} (shared / "
          "separate = {:.2f}x)\n",
          mb(p.shared_memory->parameter_bytes + p.shared_memory->peak_activation_bytes),
          mb(p.separate_memory->parameter_bytes + p.separate_memory->peak_activation_bytes),
          model_bytes(*p.shared_memory) / sep);
    }
  }
  if (p.measurement) {
    const Measurement& m = *p.measurement;
    fmt::print(
        "timed by {}; warm-up: at least {} run(s) per unit and batch size, more until the "
        "first {} timed are within {:.0f} % of the rest (at most {}){}\n",
        m.timing, m.warmup_min, m.window, 100 * m.tolerance, m.warmup_max,
        m.device_warmup_s > 0
            ? fmt::format("; the device kept busy {:.1f} s first", m.device_warmup_s)
            : std::string());
    if (m.unstable > 0)
      std::cerr << fmt::format(
          "red profile: warning: {} unit/batch size pair(s) were still getting faster after {} "
          "warm-up runs: their figures may be high (a busy or throttling machine?)\n",
          m.unstable, m.warmup_max);
  }
  fmt::print("profiled in {:.1f} s\n", p.profile_wall_s);
}

/// The units of the real runs written to DIR/units.csv (`red compare --backend torch
/// --out DIR`, `red run --out DIR`), one CalibrationRun per policy.
Expected<std::vector<CalibrationRun> > read_units_csv(const std::string& dir, const Scenario& s) {
  auto rows = read_unit_rows(dir + "/units.csv", s);
  if (!rows) {
    Error e = rows.error();
    if (e.line == 0) e.message += " (give the --out directory of a real run)";
    return e;
  }
  std::vector<CalibrationRun> runs;
  for (auto& [policy, units] : *rows)
    runs.push_back(CalibrationRun{policy, std::move(units), {}, false, {}});
  return runs;
}

/// The device the calibration's real runs use: --device, else (with --from) the device the
/// profile was measured on, else cpu.
std::string calibration_device(const ProfileArgs& a, const Profile& isolated) {
  if (a.device) return *a.device;
  const std::string measured_on = profile_device(isolated);
  return measured_on.empty() ? "cpu" : measured_on;
}

/// Plays the scenario for real with each calibration policy on the measured profile and fits
/// the simulator's model of the run (docs/FIDELITY.md). Returns the calibrated profile.
Expected<Profile> calibrate(const ProfileArgs& a, const Profile& isolated, int& code) {
  ScenarioArgs sa;
  sa.path = a.calibrate;
  sa.sets = a.calibrate_sets;
  auto s = load(sa);
  code = kBadInput;
  if (!s) return s.error();
  if (!(a.calibrate_s >= 1.0 && a.calibrate_s <= 3600.0))
    return Error{"", 0, "--calibrate-s must be in [1, 3600] seconds"};
  const int rounds = a.calibrate_rounds.value_or(std::clamp(static_cast<int>(a.calibrate_s), 1, 3));
  if (rounds < 1 || a.calibrate_s / rounds < 1.0)
    return Error{"", 0,
                 fmt::format("--calibrate-rounds must be at least 1 and leave each turn at least "
                             "1 s of the {:g} s of --calibrate-s (got {})",
                             a.calibrate_s, rounds)};
  std::vector<std::string> policies = split(a.calibrate_policies);
  for (const std::string& n : policies)
    if (!make_policy(n)) return Error{"", 0, "--calibrate-policies: " + unknown_policy_message(n)};
  if (auto e = check_profile_covers(isolated, *s)) return *e;
  if (!a.calibrate_from.empty()) {
    // Fit from real runs made before: no run here.
    std::vector<CalibrationRun> runs;
    for (const std::string& dir : a.calibrate_from) {
      auto r = read_units_csv(dir, *s);
      if (!r) return r.error();
      for (CalibrationRun& run : *r) runs.push_back(std::move(run));
    }
    CalibrationOptions o;
    auto p = calibrate_profile(isolated, *s, runs, o);
    if (!p) return p.error();
    p->calibration->policies.clear();
    for (const CalibrationRun& r : runs) p->calibration->policies.push_back(r.policy);
    fmt::print("\ncalibration on {} from {} earlier real run(s) of {} policies\n", s->name,
               a.calibrate_from.size(), runs.size());
    fmt::print("{}", calibration_table(isolated, *p));
    return p;
  }
  // The policies take turns, `rounds` turns each of calibrate_s / rounds seconds after the
  // warm-up, the first of every round moving one on. Each policy runs its own unit kinds,
  // so a slow stretch of the machine during the one turn of a policy would read as its
  // units being slow (docs/FIDELITY.md): in turns spread over the calibration, every
  // policy meets the machine's slow and fast stretches alike.
  s->duration = s->warmup + from_ms(1000.0 * a.calibrate_s / rounds);
  // The calibration's runs are made where the profile was measured: the same device (a
  // profile of a GPU calibrated on the CPU would say the GPU's units cost the CPU's times)
  // and the same threads when they were given.
  RealRunOptions real;
  real.seed = s->seed;
  real.keep_units = true;
  real.debug_sync = false;  // set once for the process by run_profile
  real.device = calibration_device(a, isolated);
  real.threads = a.threads > 0 ? a.threads : 0;
  if (auto e = check_device(real)) return *e;
  if (const auto measured_on = measured_elsewhere(isolated, real.device))
    return Error{a.from, 0,
                 "the profile was measured on " + *measured_on + "; calibrating it on " +
                     real.device + " would mix two devices' costs (--device " + *measured_on +
                     ", or measure a profile on " + real.device + ")"};
  auto backend = make_backend(*s, isolated, real);
  if (!backend) return backend.error();
  code = kRunFailure;
  std::vector<std::string> turns;
  for (int r = 0; r < rounds; ++r)
    for (std::size_t i = 0; i < policies.size(); ++i)
      turns.push_back(policies[(i + static_cast<std::size_t>(r)) % policies.size()]);
  std::vector<CalibrationRun> runs;
  for (const std::string& n : turns) {
    if (!a.quiet)
      std::cerr << fmt::format("red profile: calibrating: {} on {} for {:g} s (turn {} of {})\n", n,
                               s->name, to_s(s->duration), runs.size() + 1, turns.size());
    RuntimeReport report;
    auto r = run_real(*s, isolated, n, **backend, real, {}, &report);
    if (!r) return r.error();
    runs.push_back(calibration_run(*s, n, r->units, std::move(report.handoff_us)));
    runs.back().queued_gap_us = std::move(report.queued_gap_us);
  }
  CalibrationOptions o;
  o.seconds_per_policy = a.calibrate_s;
  auto p = calibrate_profile(isolated, *s, runs, o);
  if (p) {
    fmt::print("\ncalibration on {} ({}): the real run against the isolated profile\n", s->name,
               a.calibrate_policies);
    fmt::print("{}", calibration_table(isolated, *p));
  }
  return p;
}

int run_profile(const ProfileArgs& a);
int write_profile_file(const Profile& p, const std::string& path);

/// The profile's quality findings on stderr, one `red: warning:` line each.
void warn_quality(const Profile& p) {
  if (!p.quality || p.quality->findings.empty()) return;
  std::cerr << fmt::format("red: warning: the profile's figures are suspect ({} finding(s)):\n",
                           p.quality->findings.size());
  for (const std::string& line : quality_lines(*p.quality, p.quality->findings.size()))
    std::cerr << "red: warning: " << line << '\n';
}

/// Writes the profile JSON to `path` (nothing when empty); the exit code. The quality
/// warnings come last on stderr, after the profile is written.
int write_profile(const Profile& p, const std::string& path) {
  const int code = write_profile_file(p, path);
  warn_quality(p);
  return code;
}

int write_profile_file(const Profile& p, const std::string& path) {
  if (path.empty()) return kOk;
  // Atomically: a profile being replaced is never left half written (output_file.hpp).
  if (auto e = write_file_atomically(path, profile_to_json(p))) {
    print_error(*e);
    return kRunFailure;
  }
  fmt::print("wrote {}\n", path);
  return kOk;
}

/// `red profile --from F.json --calibrate S.yaml`: calibrates a profile measured before.
int run_calibrate_only(const ProfileArgs& a) {
  if (a.calibrate.empty()) {
    print_error(Error{"", 0, "--from needs --calibrate S.yaml (it calibrates that profile)"});
    return kBadInput;
  }
  auto p = load_profile(a.from);
  if (!p) {
    print_error(p.error());
    return kBadInput;
  }
  int code = kOk;
  const auto start = std::chrono::steady_clock::now();
  auto c = calibrate(a, *p, code);
  if (!c) {
    print_error(c.error());
    return code;
  }
  fmt::print("calibrated in {:.1f} s\n",
             std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  return write_profile(*c, a.out);
}

/// Whether `path` can be written, tried before measuring (a profile takes minutes): a file
/// created beside it under the name the final write uses, then removed. Error: the path and
/// the system's reason.
std::optional<Error> check_writable(const std::string& path) {
  if (path.empty()) return std::nullopt;
  const std::string probe = partial_path(path);
  errno = 0;
  std::FILE* f = std::fopen(probe.c_str(), "wb");
  if (f == nullptr)
    return Error{path, 0,
                 "cannot be written: " + system_reason(errno) +
                     " (checked before measuring; nothing was measured)"};
  std::fclose(f);
  std::remove(probe.c_str());
  return std::nullopt;
}

int run_profile(const ProfileArgs& a) {
  if (auto e = check_writable(a.out)) {
    print_error(*e);
    return kRunFailure;
  }
  if (a.debug_sync) std::cerr << "red profile: " << torchb::warn_on_device_sync() << '\n';
  if (!a.from.empty()) return run_calibrate_only(a);
  auto m = model_options(a);
  if (!m) {
    print_error(m.error());
    return kBadInput;
  }
  torchb::ProfileOptions o;
  o.runs = a.runs;
  o.warmup = a.warmup;
  o.warmup_max = a.warmup_max;
  o.max_batch = a.max_batch;
  o.coarse_max_batch = a.coarse_max_batch;
  o.separate = !a.no_separate;
  if (o.runs < 1 || o.warmup < 0 || o.warmup_max < 0 || o.max_batch < 1 || o.coarse_max_batch < 1) {
    print_error(Error{"", 0,
                      "need --runs >= 1, --warmup >= 0, --warmup-max >= 0, --max-batch >= 1 "
                      "and --coarse-max-batch >= 1"});
    return kBadInput;
  }
  std::vector<std::string> heads;
  {
    // Bad input (unknown head, bad manifest or TorchScript file, bad device) is told
    // apart from a failure while measuring by loading the model once before profiling.
    auto model = torchb::Model::create(*m);
    if (!model) {
      print_error(model.error());
      return kBadInput;
    }
    heads = (*model)->heads();
  }
  torchb::ProgressFn progress;
  if (!a.quiet) progress = [](const std::string& s) { std::cerr << "red profile: " << s << '\n'; };
  auto p = torchb::profile_model(*m, o, progress);
  if (!p) {
    print_error(p.error());
    return kRunFailure;
  }
  print_table(*p, heads);
  if (!a.calibrate.empty()) {
    int code = kOk;
    const auto start = std::chrono::steady_clock::now();
    auto c = calibrate(a, *p, code);
    if (!c) {
      print_error(c.error());
      return code;
    }
    const double calib_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    fmt::print("calibrated in {:.1f} s\n", calib_s);
    c->profile_wall_s = p->profile_wall_s + calib_s;
    p = std::move(c);
  }
  return write_profile(*p, a.out);
}

}  // namespace

void register_profile(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<ProfileArgs>();
  CLI::App* cmd = app.add_subcommand(
      "profile", "Measure every unit of a model on the LibTorch backend and write a profile");
  cmd->add_option("--model", args->model, "'builtin' (MIMONet) or a model manifest (YAML)")
      ->capture_default_str();
  cmd->add_option("--heads", args->heads,
                  "Heads to profile, e.g. lane,seg,steer,det (default: all)");
  cmd->add_option("--input", args->input, "Input C,H,W of the built-in model")
      ->capture_default_str();
  cmd->add_option("--device", args->device,
                  "cpu, cuda or cuda:N (default: cpu; with --from, the device that profile was "
                  "measured on). A device that is not there is an error, never a CPU run");
  cmd->add_flag("--debug-sync", args->debug_sync,
                "LibTorch warns on stderr at every operation that makes the host wait for the "
                "GPU (its CUDA sync debug mode); nothing on the CPU");
  cmd->add_option("--threads", args->threads,
                  "LibTorch intra-op threads. Default: the online CPUs less those busy with other "
                  "processes over 0.5 s at start, at least 1, so the measuring does not "
                  "oversubscribe the machine (docs/BENCHMARKS.md). 0: LibTorch's own choice "
                  "(usually one per core, busy or not)");
  cmd->add_option("--runs", args->runs, "Timed runs per unit and batch size")
      ->capture_default_str();
  cmd->add_option("--warmup", args->warmup,
                  "Untimed runs at least per unit and batch size; more until its time is stable "
                  "(0: none)")
      ->capture_default_str();
  cmd->add_option("--warmup-max", args->warmup_max,
                  "Untimed runs at most per unit and batch size (then timed even if not stable)")
      ->capture_default_str();
  cmd->add_option("--max-batch", args->max_batch, "Encoder and heads at batch sizes 1..B")
      ->capture_default_str();
  cmd->add_option("--coarse-max-batch", args->coarse_max_batch,
                  "coarse/ and separate/ units at batch sizes 1..B")
      ->capture_default_str();
  cmd->add_option("--seed", args->seed, "Seed of the built-in model's weights")
      ->check(whole_number())
      ->capture_default_str();
  cmd->add_flag("--no-separate", args->no_separate, "Skip the four separate networks");
  cmd->add_flag("--quiet", args->quiet, "No progress messages");
  cmd->add_option("--out", args->out, "Write the profile JSON here");
  cmd->add_option("--from", args->from,
                  "Calibrate this profile (JSON) instead of measuring one (with --calibrate)");
  cmd->add_option("--calibrate", args->calibrate,
                  "Then play this scenario for real and calibrate the simulator to the run "
                  "(docs/FIDELITY.md)");
  cmd->add_option("--calibrate-set", args->calibrate_sets,
                  "key=value override of the calibration scenario (like --set)");
  cmd->add_option("--calibrate-from", args->calibrate_from,
                  "Fit from the units.csv of earlier real runs of the scenario (their --out "
                  "directories) instead of playing it now");
  cmd->add_option("--calibrate-s", args->calibrate_s, "Seconds measured per calibration policy")
      ->capture_default_str();
  cmd->add_option("--calibrate-policies", args->calibrate_policies,
                  "Policies played during calibration (their units: coarse, fine, mono)")
      ->capture_default_str();
  cmd->add_option("--calibrate-rounds", args->calibrate_rounds,
                  "Turns each calibration policy takes, --calibrate-s / rounds seconds each, "
                  "the policies alternating (default 3, fewer when --calibrate-s is under 3)");
  cmd->callback([args, &exit_code] { exit_code = run_profile(*args); });
}

#endif

}  // namespace red::cli
