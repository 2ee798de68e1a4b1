#include <algorithm>
#include <cstdio>
#include <iostream>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "node_impl.hpp"
#include "red/metrics/metrics.hpp"

namespace red::dds {

namespace {

std::string fmt_double(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

// Jobs not met by cause, most first: "late 3, hopeless 2" (empty when none).
std::string not_met_text(const std::map<std::string, std::uint64_t>& by_cause) {
  std::vector<std::pair<std::string, std::uint64_t>> v(by_cause.begin(), by_cause.end());
  std::stable_sort(v.begin(), v.end(),
                   [](const auto& a, const auto& b) { return a.second > b.second; });
  std::string out;
  for (const auto& [cause, n] : v)
    out += (out.empty() ? "" : ", ") + cause + " " + std::to_string(n);
  return out;
}

}  // namespace

void Node::Impl::publish_diagnostics() {
  for (double v : runtime->decision_us_since(decisions_seen))
    keep_newest(decisions_us, decisions_kept++, kDecisionWindow, v);
  std::deque<std::string> text;  // what the message borrows
  const auto s = [&text](std::string v) { return borrow(text.emplace_back(std::move(v))); };
  std::vector<DiagnosticStatus> status;
  std::deque<std::vector<KeyValue>> values;
  const auto add = [&](std::uint8_t level, const std::string& name, const std::string& message,
                       const std::vector<std::pair<std::string, std::string>>& kv) {
    auto& v = values.emplace_back();
    for (const auto& [k, x] : kv) v.push_back({s(k), s(x)});
    DiagnosticStatus st{};
    st.level_ = level;
    st.name_ = s(name);
    st.message_ = s(message);
    st.hardware_id_ = s("red");
    borrow(st.values_, v);
    status.push_back(st);
  };
  {
    std::lock_guard lock(stats_mu);
    for (std::size_t i = 0; i < stats.size(); ++i) {
      const OpStats& st = stats[i];
      const OutcomeTally& t = st.tally;
      const double miss = t.miss_rate();
      std::vector<double> lat = st.latency_ms;
      std::sort(lat.begin(), lat.end());
      add(miss > 0.05 ? 1 : 0, "red: " + scenario.operation_name(static_cast<int>(i)),
          miss > 0.05 ? "missing deadlines" : "ok",
          {{"jobs", std::to_string(t.decided())},  // ended, the unfinished aside
           {"completed", std::to_string(t.completed())},
           {"miss_rate", fmt_double(miss)},
           {"drop_rate", fmt_double(t.drop_rate())},
           {"qoe", fmt_double(t.qoe())},
           {"latency_p50_ms", fmt_double(percentile_sorted(lat, 0.5))},
           {"latency_p99_ms", fmt_double(percentile_sorted(lat, 0.99))},
           {"not_met", not_met_text(st.not_met)}});
    }
  }
  std::string silent;
  std::vector<char> is_silent(sensors.size(), 0);
  NodeCounters c;
  {
    std::lock_guard lock(counters_mu);
    c = counters;
  }
  {
    std::lock_guard lock(frames_mu);
    const TimePoint now = clock.now();
    for (std::size_t i = 0; i < sensors.size(); ++i) {
      const double rate = scenario.sensors[i].rate_hz;
      const Duration quiet{static_cast<std::int64_t>(options.silent_periods / rate * 1e9)};
      if (sensors[i].last && now - *sensors[i].last <= quiet) continue;
      is_silent[i] = 1;
      silent += (silent.empty() ? "" : ",") + scenario.sensors[i].name;
    }
  }
  // A sensor that is silent though a writer is matched on its topic: its frames are sent
  // but do not arrive whole (too large for the transport, most often).
  // Two diagnostics in a row (a second), so that a writer matched just before it starts
  // publishing is not taken for one whose frames are lost.
  std::string matched_but_silent;
  matched_silent_ticks.resize(readers.size(), 0);
  for (std::size_t i = 0; i < readers.size(); ++i) {
    dds_subscription_matched_status_t st{};
    const bool now_silent =
        is_silent[i] != 0 &&
        dds_get_subscription_matched_status(readers[i], &st) == DDS_RETCODE_OK &&
        st.current_count > 0;
    matched_silent_ticks[i] = now_silent ? matched_silent_ticks[i] + 1 : 0;
    if (matched_silent_ticks[i] >= 2)
      matched_but_silent += (matched_but_silent.empty() ? "" : ",") + topics.sensors[i];
  }
  std::vector<double> dec = decisions_us;
  std::vector<std::pair<std::string, std::string>> kv = {
      {"policy", options.policy},
      {"decision_p99_us", fmt_double(percentile(dec, 0.99))},
      {"frames", std::to_string(c.frames)},
      {"released", std::to_string(c.released)},
      {"silent_sensors", silent}};
  std::uint64_t rejected = 0;
  for (int r = 0; r < kRejectKinds; ++r) {
    rejected += c.rejected[static_cast<std::size_t>(r)];
    kv.emplace_back(std::string("rejected_") + to_string(static_cast<Reject>(r)),
                    std::to_string(c.rejected[static_cast<std::size_t>(r)]));
  }
  kv.emplace_back("matched_but_silent", matched_but_silent);
  if (options.security) {
    const SecurityRefusals r = security_refusals();
    kv.emplace_back("security_enclave", options.security->name);
    kv.emplace_back("refused_participants", std::to_string(r.participants));
    kv.emplace_back("refused_endpoints", std::to_string(r.endpoints));
  }
  add(silent.empty() && rejected == 0 ? 0 : 1, "red: node",
      silent.empty() ? "ok"
      : matched_but_silent.empty()
          ? "silent sensor(s): " + silent
          : "silent sensor(s): " + silent + "; a writer is matched on " + matched_but_silent +
                " but no frame arrives whole (too large for the "
                "transport? docs/ROS2.md, Large frames)",
      kv);
  if (!matched_but_silent.empty() && !warned_matched_but_silent.exchange(true))
    std::cerr << "red node: a writer is matched on " << matched_but_silent
              << " but no frame arrives whole: frames too large for the transport are lost "
                 "(docs/ROS2.md, \"Large frames\")\n";
  DiagnosticArray a{};
  stamp_now(a.header_.stamp_.sec_, a.header_.stamp_.nanosec_);
  a.header_.frame_id_ = s("");
  borrow(a.status_, status);
  dds_write(diag_writer, &a);
  std::lock_guard lock(counters_mu);
  ++counters.diagnostics;
}

}  // namespace red::dds
