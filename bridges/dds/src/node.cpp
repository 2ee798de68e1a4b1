#include <algorithm>
#include <chrono>
#include <thread>

#include <pthread.h>
#include <sched.h>

#include "node_impl.hpp"
#include "red/sched/policy.hpp"
#include "red/sim/run.hpp"

namespace red::dds {

OutputKind output_kind(const std::string& head) noexcept {
  if (head == "steer") return OutputKind::Velocity;
  if (head == "det") return OutputKind::Detections;
  return OutputKind::Mask;
}

NodeTopics node_topics(const Scenario& s, const Remaps& remaps) {
  NodeTopics t;
  for (const SensorSpec& sensor : s.sensors)
    t.sensors.push_back(
        remaps.apply(sensor.topic.empty() ? "/" + sensor.name + "/image_raw" : sensor.topic));
  const auto add = [&](int op, const OperationSpec& spec) {
    for (const NodeSpec& n : spec.nodes) {
      const auto key = std::make_pair(op, n.name);
      t.nodes[key] =
          remaps.apply(n.topic.empty() ? "/red/" + s.operation_name(op) + "/" + n.name : n.topic);
      t.heads[key] = n.head;
    }
  };
  for (int i = 0; i < s.operation_count(); ++i)
    if (s.initial[static_cast<std::size_t>(i)]) add(i, *s.initial[static_cast<std::size_t>(i)]);
  for (const EventSpec& e : s.events)
    for (const auto& [op, spec] : e.changes)
      if (spec) add(op, *spec);
  t.diagnostics = remaps.apply("/diagnostics");
  return t;
}

Node::Impl::Impl(const Scenario& s, const Profile& p, Backend& b, NodeOptions o)
    : scenario(s), profile(p), backend(b), options(std::move(o)) {
  // Frame arrivals are the releases (docs/ROS2.md): run until stop() or the given duration.
  scenario.duration = options.duration.value_or(std::chrono::hours{24 * 365});
  topics = node_topics(scenario, options.remaps);
  sensors.resize(scenario.sensors.size());
  stats.resize(static_cast<std::size_t>(scenario.operation_count()));
}

Node::Impl::~Impl() {
  if (domain) {
    for (dds_entity_t r : readers) dds_delete(r);
    for (auto& [t, w] : writers) dds_delete(w);
    if (diag_writer > 0) dds_delete(diag_writer);
    if (waitset > 0) dds_delete(waitset);
    if (wake > 0) dds_delete(wake);
  }
}

Expected<bool> Node::Impl::open() {
  // What DDS Security refuses is counted from Cyclone's log and, unless the configuration
  // traces on its own, from its discovery trace (docs/ROS2.md, "Security").
  std::string config = options.config;
  if (options.security) {
    watch_security_log();
    if (!configures_tracing(config)) {
      config = (config.empty() ? loopback_config() : config) + "," + security_trace_config();
      watch_security_trace(!governance_allows_unauthenticated(*options.security));
    }
  }
  auto d = Domain::open(options.domain, config, options.shared_memory,
                        options.security ? &*options.security : nullptr);
  if (!d) return d.error();
  domain = std::move(*d);
  const dds_entity_t pp = domain->participant();
  const auto fail = [](const std::string& what, dds_return_t rc) {
    return Error{"", 0, what + ": " + dds_strretcode(rc)};
  };
  dds_qos_t* in_qos = make_qos(options.qos.input);
  dds_qos_t* out_qos = make_qos(options.qos.output);
  waitset = dds_create_waitset(pp);
  wake = dds_create_guardcondition(pp);
  dds_waitset_attach(waitset, wake, -1);
  Expected<bool> result = true;
  // A writer DDS refuses to match (another type, an incompatible QoS) is reported to a
  // listener, one call per writer (a waitset would see only the last of several).
  reader_ctx.resize(topics.sensors.size());
  for (std::size_t i = 0; i < topics.sensors.size() && result; ++i) {
    const dds_entity_t topic =
        dds_create_topic(pp, &sensor_msgs_msg_dds__Image__desc,
                         dds_topic_name(topics.sensors[i]).c_str(), nullptr, nullptr);
    reader_ctx[i] = {this, i};
    dds_listener_t* l = dds_create_listener(nullptr);
    dds_lset_requested_incompatible_qos_arg(l, &Impl::on_unmatched_writer, &reader_ctx[i], true);
    dds_lset_sample_lost_arg(l, &Impl::on_sample_lost, &reader_ctx[i], true);
    dds_lset_sample_rejected_arg(l, &Impl::on_sample_rejected, &reader_ctx[i], true);
    const dds_entity_t r = topic < 0 ? topic : dds_create_reader(pp, topic, in_qos, l);
    dds_delete_listener(l);
    if (r < 0) {
      result = fail("cannot subscribe to " + topics.sensors[i], r);
      break;
    }
    dds_set_status_mask(r, DDS_DATA_AVAILABLE_STATUS);
    dds_waitset_attach(waitset, r, static_cast<dds_attach_t>(i));
    readers.push_back(r);
  }
  for (const auto& [key, name] : topics.nodes) {
    if (!result) break;
    const int head = topics.heads[key];
    if (head < 0 || writers.count(name) != 0) continue;
    const dds_topic_descriptor_t* desc = &sensor_msgs_msg_dds__Image__desc;
    switch (output_kind(scenario.model.heads[static_cast<std::size_t>(head)])) {
      case OutputKind::Velocity:
        desc = &geometry_msgs_msg_dds__Twist__desc;
        break;
      case OutputKind::Detections:
        desc = &vision_msgs_msg_dds__Detection2DArray__desc;
        break;
      case OutputKind::Mask:
        break;
    }
    const dds_entity_t topic =
        dds_create_topic(pp, desc, dds_topic_name(name).c_str(), nullptr, nullptr);
    const dds_entity_t w = topic < 0 ? topic : dds_create_writer(pp, topic, out_qos, nullptr);
    if (w < 0) {
      result =
          fail("cannot publish " + name + " (is it remapped onto a topic of another type?)", w);
      break;
    }
    writers[name] = w;
    if (desc == &geometry_msgs_msg_dds__Twist__desc) {
      // Twist has no header: the same values with the frame's header beside it.
      const std::string stamped = name + "/stamped";
      const dds_entity_t st = dds_create_topic(pp, &geometry_msgs_msg_dds__TwistStamped__desc,
                                               dds_topic_name(stamped).c_str(), nullptr, nullptr);
      const dds_entity_t sw = st < 0 ? st : dds_create_writer(pp, st, out_qos, nullptr);
      if (sw < 0) {
        result = fail("cannot publish " + stamped, sw);
        break;
      }
      writers[stamped] = sw;
    }
  }
  if (result) {
    const dds_entity_t topic =
        dds_create_topic(pp, &diagnostic_msgs_msg_dds__DiagnosticArray__desc,
                         dds_topic_name(topics.diagnostics).c_str(), nullptr, nullptr);
    diag_writer = topic < 0 ? topic : dds_create_writer(pp, topic, out_qos, nullptr);
    if (diag_writer < 0) result = fail("cannot publish " + topics.diagnostics, diag_writer);
  }
  dds_delete_qos(in_qos);
  dds_delete_qos(out_qos);
  return result;
}

// With --realtime the node's own threads run under SCHED_FIFO as the runtime's do (a
// frame is a release: the receiver at the synchronizer's priority, one above the
// handlers'; the publisher below the handlers, so that it never delays a decision).
// Otherwise any process on the machine can keep a frame or an output waiting for
// milliseconds. Best effort: the runtime reports whether SCHED_FIFO is permitted.
void Node::Impl::make_realtime(std::thread& t, int priority) const {
  if (!options.realtime) return;
  sched_param sp{};
  sp.sched_priority = std::max(1, priority);
  (void)pthread_setschedparam(t.native_handle(), SCHED_FIFO, &sp);
}

RuntimeReport Node::Impl::run() {
  std::thread receiver([this] { receive_main(); });
  std::thread publisher([this] { publish_main(); });
  make_realtime(receiver, RuntimeOptions{}.rt_priority + 1);
  make_realtime(publisher, RuntimeOptions{}.rt_priority - 1);
  RuntimeReport report = runtime->run();
  receiving.store(false, std::memory_order_release);
  dds_set_guardcondition(wake, true);
  receiver.join();
  {
    std::lock_guard lock(pub_mu);
    publishing = false;
  }
  pub_cv.notify_one();
  publisher.join();
  return report;
}

Expected<std::unique_ptr<Node>> Node::make(const Scenario& scenario, const Profile& profile,
                                           Backend& backend, NodeOptions options) {
  // The scenario's policy options (and the CLI's --with) apply, as in red run; checked here
  // too, for a caller that loaded the scenario itself.
  if (auto e = check_policy_options(scenario)) return *e;
  auto policy = make_policy(options.policy, policy_options(scenario, options.policy));
  if (!policy) return Error{"", 0, "unknown policy '" + options.policy + "'"};
  auto impl = std::make_unique<Impl>(scenario, profile, backend, std::move(options));
  if (auto r = impl->open(); !r) return r.error();
  RuntimeOptions ro;
  ro.realtime = impl->options.realtime;
  ro.external_frames = true;
  ro.watchdog_x = impl->options.watchdog_x;
  impl->runtime =
      std::make_unique<Runtime>(impl->scenario, profile, std::move(policy), backend, ro);
  impl->runtime->add_observer(impl.get());
  return std::unique_ptr<Node>(new Node(std::move(impl)));
}

Node::Node(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Node::~Node() = default;

RuntimeReport Node::run() {
  return impl_->run();
}

void Node::add_observer(Observer* o) {
  impl_->runtime->add_observer(o);
}

void Node::stop() {
  impl_->runtime->stop();
}

NodeCounters Node::counters() const {
  NodeCounters c;
  {
    std::lock_guard lock(impl_->counters_mu);
    c = impl_->counters;
  }
  if (impl_->options.security) {
    const SecurityRefusals r = security_refusals();
    c.refused_participants = r.participants;
    c.refused_endpoints = r.endpoints;
  }
  return c;
}

Node::Timings Node::timings() const {
  std::lock_guard lock(impl_->counters_mu);
  Timings t = impl_->timings;
  t.released_intake_us = impl_->released_intake_us;
  t.taken_released_us = impl_->taken_released_us;
  return t;
}

const NodeTopics& Node::topics() const {
  return impl_->topics;
}

}  // namespace red::dds
