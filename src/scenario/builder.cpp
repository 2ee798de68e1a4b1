#include "red/scenario/builder.hpp"

#include <yaml-cpp/yaml.h>

#include <regex>
#include <utility>

#include "red/scenario/loader.hpp"

namespace red {

namespace {

double ms(Duration d) {
  return to_ms(d);
}
double seconds(Duration d) {
  return static_cast<double>(d.count()) / 1e9;
}

}  // namespace

// ---- OperationBuilder ----------------------------------------------------------------

OperationBuilder& OperationBuilder::trigger(std::string sensor) {
  trigger_ = std::move(sensor);
  return *this;
}
OperationBuilder& OperationBuilder::rate(double hz) {
  rate_hz_ = hz;
  return *this;
}
OperationBuilder& OperationBuilder::phase(Duration d) {
  phase_ = d;
  return *this;
}
OperationBuilder& OperationBuilder::release_count(int count) {
  release_count_ = count;
  return *this;
}
OperationBuilder& OperationBuilder::deadline(Duration d) {
  deadline_ = d;
  critical_path_x_.reset();
  return *this;
}
OperationBuilder& OperationBuilder::deadline_critical_path(double factor) {
  critical_path_x_ = factor;
  deadline_.reset();
  return *this;
}
OperationBuilder& OperationBuilder::criticality(int c) {
  criticality_ = c;
  return *this;
}
OperationBuilder& OperationBuilder::max_inflight(int n) {
  max_inflight_ = n;
  return *this;
}
OperationBuilder& OperationBuilder::depends_on(std::string operation) {
  depends_on_ = std::move(operation);
  return *this;
}
OperationBuilder& OperationBuilder::inference(std::string node, std::string head,
                                              std::string sensor) {
  nodes_.push_back(Node{std::move(node), std::move(head), std::move(sensor), {}, {}, {}});
  return *this;
}
OperationBuilder& OperationBuilder::plain(std::string node, Duration cost) {
  return plain(std::move(node), cost, cost);
}
OperationBuilder& OperationBuilder::plain(std::string node, Duration mean, Duration p99) {
  nodes_.push_back(Node{std::move(node), {}, {}, mean, p99, {}});
  return *this;
}
OperationBuilder& OperationBuilder::node_deadline(const std::string& node, Duration d) {
  for (auto& n : nodes_)
    if (n.name == node) {
      n.deadline = d;
      return *this;
    }
  misuse_.push_back("node_deadline: operation '" + name_ + "' has no node '" + node +
                    "' (add the node first)");
  return *this;
}
OperationBuilder& OperationBuilder::edge(std::string from, std::string to) {
  edges_.emplace_back(std::move(from), std::move(to));
  return *this;
}

// ---- ScenarioBuilder -----------------------------------------------------------------

struct ScenarioBuilder::Data {
  std::string name;
  Duration duration{std::chrono::seconds{10}};
  std::optional<Duration> warmup, sync_cost, gamma;
  std::optional<int> queue_depth;
  std::optional<std::uint64_t> seed;
  int lanes = 1;
  std::vector<std::string> heads{"lane", "seg", "steer", "det"};
  std::string profile;
  std::optional<int> max_batch;
  std::optional<double> qoe_lambda;
  struct Sensor {
    std::string name;
    double rate_hz;
    Duration phase, jitter;
  };
  std::vector<Sensor> sensors;
  // unique_ptr: the references operation() hands out stay valid as operations are added.
  std::vector<std::unique_ptr<OperationBuilder>> operations;
};

ScenarioBuilder::ScenarioBuilder(std::string name) : d_(std::make_unique<Data>()) {
  d_->name = std::move(name);
}
ScenarioBuilder::~ScenarioBuilder() = default;
ScenarioBuilder::ScenarioBuilder(ScenarioBuilder&&) noexcept = default;
ScenarioBuilder& ScenarioBuilder::operator=(ScenarioBuilder&&) noexcept = default;

ScenarioBuilder& ScenarioBuilder::duration(Duration d) {
  d_->duration = d;
  return *this;
}
ScenarioBuilder& ScenarioBuilder::warmup(Duration d) {
  d_->warmup = d;
  return *this;
}
ScenarioBuilder& ScenarioBuilder::seed(std::uint64_t s) {
  d_->seed = s;
  return *this;
}
ScenarioBuilder& ScenarioBuilder::lanes(int n) {
  d_->lanes = n;
  return *this;
}
ScenarioBuilder& ScenarioBuilder::sync_cost(Duration d) {
  d_->sync_cost = d;
  return *this;
}
ScenarioBuilder& ScenarioBuilder::queue_depth(int n) {
  d_->queue_depth = n;
  return *this;
}
ScenarioBuilder& ScenarioBuilder::heads(std::vector<std::string> names) {
  d_->heads = std::move(names);
  return *this;
}
ScenarioBuilder& ScenarioBuilder::profile(std::string path) {
  d_->profile = std::move(path);
  return *this;
}
ScenarioBuilder& ScenarioBuilder::gamma(Duration d) {
  d_->gamma = d;
  return *this;
}
ScenarioBuilder& ScenarioBuilder::max_batch(int n) {
  d_->max_batch = n;
  return *this;
}
ScenarioBuilder& ScenarioBuilder::qoe_lambda(double lambda) {
  d_->qoe_lambda = lambda;
  return *this;
}
ScenarioBuilder& ScenarioBuilder::sensor(std::string name, double rate_hz, Duration phase,
                                         Duration jitter) {
  d_->sensors.push_back(Data::Sensor{std::move(name), rate_hz, phase, jitter});
  return *this;
}
OperationBuilder& ScenarioBuilder::operation(std::string name) {
  d_->operations.push_back(std::unique_ptr<OperationBuilder>(new OperationBuilder(name)));
  return *d_->operations.back();
}

std::string ScenarioBuilder::to_yaml() const {
  const Data& d = *d_;
  YAML::Emitter out;
  // Enough digits that every nanosecond count survives the round trip through ms.
  out.SetDoublePrecision(17);
  out << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value << d.name;
  out << YAML::Key << "duration_s" << YAML::Value << seconds(d.duration);
  if (d.warmup) out << YAML::Key << "warmup_s" << YAML::Value << seconds(*d.warmup);
  if (d.seed) out << YAML::Key << "seed" << YAML::Value << *d.seed;
  out << YAML::Key << "device" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "lanes" << YAML::Value << d.lanes;
  if (d.sync_cost) out << YAML::Key << "sync_cost_us" << YAML::Value << ms(*d.sync_cost) * 1e3;
  if (d.queue_depth) out << YAML::Key << "queue_depth" << YAML::Value << *d.queue_depth;
  out << YAML::EndMap;
  out << YAML::Key << "model" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "builtin" << YAML::Value << "mimonet";
  out << YAML::Key << "heads" << YAML::Value << YAML::Flow << d.heads;
  out << YAML::EndMap;
  if (!d.profile.empty()) out << YAML::Key << "profile" << YAML::Value << d.profile;
  if (d.gamma || d.max_batch || d.qoe_lambda) {
    out << YAML::Key << "scheduler" << YAML::Value << YAML::BeginMap;
    if (d.gamma) out << YAML::Key << "gamma_ms" << YAML::Value << ms(*d.gamma);
    if (d.max_batch) out << YAML::Key << "max_batch" << YAML::Value << *d.max_batch;
    if (d.qoe_lambda) out << YAML::Key << "qoe_lambda" << YAML::Value << *d.qoe_lambda;
    out << YAML::EndMap;
  }
  if (!d.sensors.empty()) {
    out << YAML::Key << "sensors" << YAML::Value << YAML::BeginMap;
    for (const auto& s : d.sensors) {
      out << YAML::Key << s.name << YAML::Value << YAML::BeginMap;
      out << YAML::Key << "rate_hz" << YAML::Value << s.rate_hz;
      if (s.phase != Duration{0}) out << YAML::Key << "phase_ms" << YAML::Value << ms(s.phase);
      if (s.jitter != Duration{0}) out << YAML::Key << "jitter_ms" << YAML::Value << ms(s.jitter);
      out << YAML::EndMap;
    }
    out << YAML::EndMap;
  }
  out << YAML::Key << "operations" << YAML::Value << YAML::BeginSeq;
  for (const auto& op : d.operations) {
    out << YAML::BeginMap;
    out << YAML::Key << "name" << YAML::Value << op->name_;
    if (op->trigger_) out << YAML::Key << "trigger" << YAML::Value << *op->trigger_;
    if (op->rate_hz_) out << YAML::Key << "rate_hz" << YAML::Value << *op->rate_hz_;
    if (op->phase_) out << YAML::Key << "phase_ms" << YAML::Value << ms(*op->phase_);
    if (op->release_count_) {
      out << YAML::Key << "release" << YAML::Value << YAML::BeginMap;
      out << YAML::Key << "count" << YAML::Value << *op->release_count_ << YAML::EndMap;
    }
    if (op->deadline_) {
      out << YAML::Key << "deadline_ms" << YAML::Value << ms(*op->deadline_);
    } else if (op->critical_path_x_) {
      out << YAML::Key << "deadline_ms" << YAML::Value << YAML::BeginMap;
      out << YAML::Key << "critical_path_x" << YAML::Value << *op->critical_path_x_;
      out << YAML::EndMap;
    }
    if (op->criticality_) out << YAML::Key << "criticality" << YAML::Value << *op->criticality_;
    if (op->max_inflight_) out << YAML::Key << "max_inflight" << YAML::Value << *op->max_inflight_;
    if (op->depends_on_) {
      out << YAML::Key << "depends_on" << YAML::Value << YAML::BeginMap;
      out << YAML::Key << "operation" << YAML::Value << *op->depends_on_;
      out << YAML::Key << "use" << YAML::Value << "latest" << YAML::EndMap;
    }
    // A duplicate node name would collapse in a YAML map; the loader would never see it.
    // Emit it twice anyway: yaml-cpp keeps both keys, and the loader reports the duplicate.
    out << YAML::Key << "nodes" << YAML::Value << YAML::BeginMap;
    for (const auto& n : op->nodes_) {
      out << YAML::Key << n.name << YAML::Value << YAML::BeginMap;
      if (n.mean) {
        out << YAML::Key << "cost" << YAML::Value << YAML::BeginMap;
        out << YAML::Key << "mean_ms" << YAML::Value << ms(*n.mean);
        out << YAML::Key << "p99_ms" << YAML::Value << ms(*n.p99) << YAML::EndMap;
      } else {
        out << YAML::Key << "head" << YAML::Value << n.head;
        out << YAML::Key << "sensor" << YAML::Value << n.sensor;
      }
      if (n.deadline) out << YAML::Key << "deadline_ms" << YAML::Value << ms(*n.deadline);
      out << YAML::EndMap;
    }
    out << YAML::EndMap;
    if (!op->edges_.empty()) {
      out << YAML::Key << "edges" << YAML::Value << YAML::BeginSeq;
      for (const auto& [from, to] : op->edges_)
        out << YAML::Flow << YAML::BeginSeq << from << to << YAML::EndSeq;
      out << YAML::EndSeq;
    }
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::EndMap;
  return out.c_str();
}

Expected<Scenario> ScenarioBuilder::build() const {
  const std::string label = "scenario builder '" + d_->name + "'";
  for (const auto& op : d_->operations)
    if (!op->misuse_.empty()) return Error{label, 0, op->misuse_.front()};
  std::string text;
  try {
    text = to_yaml();
  } catch (const std::exception& e) {
    return Error{label, 0, std::string("cannot build the scenario: ") + e.what()};
  }
  // Line numbers refer to the generated text, which the user never wrote: drop them (the
  // loader's messages name the operation and node anyway).
  Expected<Scenario> s = parse_scenario(text, "");
  if (!s) {
    static const std::regex kLineRef(R"( \(first at line [0-9]+\))");
    return Error{label, 0, std::regex_replace(s.error().message, kLineRef, "")};
  }
  s->file.clear();
  return s;
}

}  // namespace red
