#include <algorithm>
#include <chrono>
#include <cmath>

#include "node_impl.hpp"
#include "red/metrics/metrics.hpp"

namespace red::dds {

void Node::Impl::on_unit_end(const Dispatch& d, TimePoint, UnitStatus s) {
  if (s != UnitStatus::Completed) return;
  for (const Member& m : d.members) {
    if (m.graph == nullptr || m.unit < 0) continue;
    const RefinedUnit& u = m.graph->units[static_cast<std::size_t>(m.unit)];
    for (int n : u.produces) {
      const NodeSpec& spec = m.graph->spec->nodes[static_cast<std::size_t>(n)];
      if (spec.head < 0) continue;
      finished_heads[m.job].push_back(
          {m.operation, spec.name, spec.head, spec.sensor, m.frame, TimePoint{0}});
    }
  }
}

// A job released on the receiving thread while it pushes a frame is that frame's release
// (the runtime released it there, holding the scheduler's lock): the first one stamps it.
void Node::Impl::on_job_release(const JobRecord&) {
  if (pushing_node == this && !released_at) released_at = clock.now();
}

void Node::Impl::on_job_end(const JobRecord& j) {
  std::vector<Output> outs;
  if (auto it = finished_heads.find(j.id); it != finished_heads.end()) {
    outs = std::move(it->second);
    finished_heads.erase(it);
  }
  const bool completed = j.outcome == JobOutcome::Met || j.outcome == JobOutcome::Missed;
  {
    std::lock_guard lock(stats_mu);
    OpStats& st = stats[static_cast<std::size_t>(j.operation)];
    double qoe = 0;
    if (completed) {
      const Duration r = j.finish - j.release;
      qoe = qoe_score(r, j.deadline - j.release, scenario.scheduler.qoe_lambda);
      const double ms = to_ms(r);
      keep_newest(st.latency_ms, st.completed++, kLatencyWindow, ms);
    }
    st.tally.add(j.outcome, qoe);
    if (j.outcome != JobOutcome::Met && j.outcome != JobOutcome::Unfinished)
      ++st.not_met[j.outcome == JobOutcome::Missed ? std::string("late")
                   : j.reason.empty()              ? std::string(to_string(j.outcome))
                                                   : std::string(j.reason)];
  }
  // A finished job publishes what it computed; a dropped one (strict) nothing (docs/ROS2.md).
  if (!completed) {
    std::lock_guard lock(counters_mu);
    if (j.outcome != JobOutcome::Unfinished) ++counters.jobs_without_output;
    return;
  }
  {
    const TimePoint now = clock.now();
    std::lock_guard lock(pub_mu);
    for (Output& o : outs) {
      o.ended = now;
      queue.push_back(std::move(o));
    }
  }
  pub_cv.notify_one();
}

// The frame a head read, if still kept: its header and (shared, not copied) luminance.
bool Node::Impl::frame_of(const Output& o, HeaderValue& header,
                          std::shared_ptr<const ConvertedImage>& gray,
                          std::optional<FrameStats>& fs) {
  std::lock_guard lock(frames_mu);
  const FrameSlot& slot = sensors[static_cast<std::size_t>(o.sensor)].ring[o.frame % kFrameRing];
  if (slot.id != o.frame || !slot.gray) return false;
  header = slot.header;
  gray = slot.gray;
  fs = slot.stats;
  return true;
}

// The published values are computed from the frame by fixed rules (the built-in model's
// weights are random, docs/DESIGN.md, "Built-in model"): lane a bright-pixel mask, seg four
// luminance classes, steer the left/right balance, det the box around the brightest pixels.
void Node::Impl::publish(const Output& o, const FrameView& g, const FrameStats& f,
                         const HeaderValue& hv) {
  const std::string& head = scenario.model.heads[static_cast<std::size_t>(o.head)];
  const auto topic = topics.nodes.find(std::make_pair(o.operation, o.node));
  if (topic == topics.nodes.end()) return;
  const auto wit = writers.find(topic->second);
  if (wit == writers.end()) return;
  const std::size_t n_px = static_cast<std::size_t>(g.width) * static_cast<std::size_t>(g.height);
  switch (output_kind(head)) {
    case OutputKind::Mask: {
      // Computed into the publisher's own buffer; dds_write serializes it (its one copy).
      mask.resize(n_px);
      if (head == "seg") {
        for (std::size_t i = 0; i < n_px; ++i) mask[i] = static_cast<std::uint8_t>(g.data[i] / 64);
      } else {
        // An integer pixel is above the mean exactly when it is above its floor.
        const auto above = static_cast<std::uint8_t>(std::min(255.0, std::floor(f.mean)));
        for (std::size_t i = 0; i < n_px; ++i)
          mask[i] = static_cast<std::uint8_t>(g.data[i] > above ? 255 : 0);
      }
      Image m{};
      hv.fill(m.header_);
      m.height_ = static_cast<std::uint32_t>(g.height);
      m.width_ = static_cast<std::uint32_t>(g.width);
      m.encoding_ = const_cast<char*>("mono8");
      m.step_ = static_cast<std::uint32_t>(g.width);
      borrow(m.data_, mask);
      dds_write(wit->second, &m);
      std::lock_guard lock(counters_mu);
      ++counters.masks;
      break;
    }
    case OutputKind::Velocity: {
      const double half = std::max(1.0, static_cast<double>(g.width * g.height) / 2.0);
      Twist t{};
      t.linear_.x_ = f.mean / 255.0;
      t.angular_.z_ = (f.right - f.left) / half / 255.0;
      dds_write(wit->second, &t);
      if (const auto sit = writers.find(wit->first + "/stamped"); sit != writers.end()) {
        TwistStamped ts{};
        hv.fill(ts.header_);
        ts.twist_ = t;
        dds_write(sit->second, &ts);
      }
      std::lock_guard lock(counters_mu);
      ++counters.twists;
      break;
    }
    case OutputKind::Detections: {
      const int x0 = f.x0, y0 = f.y0, x1 = f.x1, y1 = f.y1, n = f.bright;
      Detection2DArray a{};
      hv.fill(a.header_);
      std::vector<Detection2D> dets;
      std::vector<ObjectHypothesisWithPose> hyp(1);
      const std::string cls = "bright", id;
      if (n > 0) {
        const double area = static_cast<double>((x1 - x0 + 1) * (y1 - y0 + 1));
        hyp[0].hypothesis_.class_id_ = borrow(cls);
        hyp[0].hypothesis_.score_ = static_cast<double>(n) / area;
        hyp[0].pose_.pose_.orientation_.w_ = 1.0;
        Detection2D d{};
        hv.fill(d.header_);
        borrow(d.results_, hyp);
        d.bbox_.center_.position_.x_ = (x0 + x1) / 2.0;
        d.bbox_.center_.position_.y_ = (y0 + y1) / 2.0;
        d.bbox_.size_x_ = x1 - x0 + 1;
        d.bbox_.size_y_ = y1 - y0 + 1;
        d.id_ = borrow(id);
        dets.push_back(d);
      }
      borrow(a.detections_, dets);
      dds_write(wit->second, &a);
      std::lock_guard lock(counters_mu);
      ++counters.detections;
      break;
    }
  }
}

void Node::Impl::publish_main() {
  TimePoint next_diag = clock.now() + options.diagnostics_period;
  HeaderValue header;
  std::shared_ptr<const ConvertedImage> gray;
  std::optional<FrameStats> fs;
  for (;;) {
    std::optional<Output> item;
    bool done = false;
    double woke_us = -1;  // queued -> taken here, when this thread waited for it
    {
      std::unique_lock lock(pub_mu);
      const bool waits = queue.empty();
      const auto wall = std::chrono::steady_clock::now() + (next_diag - clock.now());
      pub_cv.wait_until(lock, wall, [&] { return !queue.empty() || !publishing; });
      if (!queue.empty()) {
        item = std::move(queue.front());
        queue.pop_front();
        if (waits) woke_us = to_us(clock.now() - item->ended);
      } else {
        done = !publishing;
      }
    }
    if (item) {
      if (woke_us >= 0) {
        std::lock_guard lock(counters_mu);
        record(timings.publish_wake_us, publish_wakes++, woke_us);
      }
      if (frame_of(*item, header, gray, fs)) {
        const FrameView g = gray->pixels();
        // Computed after the release unless this job ended first (then here, alike).
        if (!fs) fs = frame_stats(g);
        publish(*item, g, *fs, header);
        gray.reset();
        const double us = to_us(clock.now() - item->ended);
        std::lock_guard lock(counters_mu);
        record(timings.publish_us, publishes++, us);
      } else {
        std::lock_guard lock(counters_mu);
        ++counters.jobs_without_output;  // its frame left the ring: never a wrong stamp
      }
    }
    if (done || clock.now() >= next_diag) {
      publish_diagnostics();
      next_diag = clock.now() + options.diagnostics_period;
    }
    if (done) return;
  }
}

}  // namespace red::dds
