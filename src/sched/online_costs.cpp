// Online cost estimates (red/sched/online_costs.hpp): the run's costs over the profile's, per
// unit and batch size, and the plan profile they scale.

#include "red/sched/online_costs.hpp"

#include <algorithm>
#include <cmath>

#include "red/graph/refine.hpp"

namespace red {

namespace {

double median_of(std::vector<float>& v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  if (v.size() % 2 == 1) return *mid;
  const float lower = *std::max_element(v.begin(), mid);
  return (static_cast<double>(lower) + static_cast<double>(*mid)) / 2.0;
}

}  // namespace

OnlineCosts::OnlineCosts(const Profile& base, const ModelSpec& model, OnlineCostOptions opt)
    : base_(base), model_(model), opt_(opt) {
  auto add = [&](std::string name) {
    Unit u;
    u.prof = base_.find(name);
    u.name = std::move(name);
    const std::size_t sizes = u.prof != nullptr ? u.prof->by_batch.size() : 1;
    u.runs.assign(sizes, 0);
    u.total.assign(sizes, Duration{0});
    u.kept.resize(sizes);
    u.applied.assign(sizes, 1.0);
    u.ring.reserve(kRing);
    units_.push_back(std::move(u));
  };
  add("encoder");
  for (const std::string& h : model_.heads) add("head/" + h);
  planned_ = units_.size();
  // Figures only: a coarse unit (encoder and head back to back, the coarse graphs of edf and
  // fifo) against the profile's own figure of it.
  for (const std::string& h : model_.heads) add("coarse/" + h);
}

void OnlineCosts::record(int unit, int batch, double ratio, Duration took, bool timed,
                         TimePoint now) {
  Unit& u = units_[static_cast<std::size_t>(unit)];
  if (u.prof == nullptr || !std::isfinite(ratio) || ratio <= 0.0) return;
  const auto b = static_cast<std::size_t>(std::clamp(batch, 1, static_cast<int>(u.runs.size())));
  const Sample s{now, static_cast<float>(ratio), static_cast<std::uint8_t>(b)};
  if (u.ring.size() < kRing) {
    u.ring.push_back(s);
  } else {
    u.ring[u.next] = s;
  }
  u.next = (u.next + 1) % kRing;
  fresh_ = true;
  if (!timed) return;
  ++u.runs[b - 1];
  u.total[b - 1] += took;
  auto& k = u.kept[b - 1];
  const auto ms = static_cast<float>(to_ms(took));
  if (k.size() < kKeep)
    k.push_back(ms);
  else
    k[static_cast<std::size_t>(u.runs[b - 1] - 1) % kKeep] = ms;  // the oldest kept
}

void OnlineCosts::observe(const Dispatch& d, Duration took, TimePoint now) {
  if (d.members.empty() || took <= Duration{0}) return;
  const auto p50 = [&](int unit, int batch) {
    const UnitProfile* p = units_[static_cast<std::size_t>(unit)].prof;
    return p != nullptr ? p->at(batch).p50 : Duration{0};
  };
  switch (d.kind) {
    case UnitKind::Encoder:
    case UnitKind::Head: {
      const int unit = d.kind == UnitKind::Encoder ? 0 : 1 + d.head;
      if (d.kind == UnitKind::Head &&
          (d.head < 0 || d.head >= static_cast<int>(model_.heads.size())))
        return;
      const Duration expect = p50(unit, d.batch);
      if (expect <= Duration{0}) return;
      record(unit, d.batch, static_cast<double>(took.count()) / static_cast<double>(expect.count()),
             took, true, now);
      return;
    }
    case UnitKind::Coarse:
    case UnitKind::Mono: {
      // Several parts in one run: the run's time over the parts' medians, counted for each.
      const RefinedGraph* g = d.members.front().graph;
      if (g == nullptr) return;
      const RefinedUnit& ru = g->units[static_cast<std::size_t>(d.members.front().unit)];
      // Two passes over the parts (no list of them: a decision allocates nothing).
      Duration expect{0};
      for_each_part(*g, ru, [&](const UnitPart& p) {
        if (p.kind == UnitPart::Kind::Encoder) expect += p50(0, 1);
        if (p.kind == UnitPart::Kind::Head) expect += p50(1 + p.head, 1);
        if (p.kind == UnitPart::Kind::Plain && p.cost != nullptr) expect += p.cost->mean;
      });
      if (expect <= Duration{0}) return;
      const double r = static_cast<double>(took.count()) / static_cast<double>(expect.count());
      for_each_part(*g, ru, [&](const UnitPart& p) {
        if (p.kind == UnitPart::Kind::Encoder) record(0, 1, r, took, false, now);
        if (p.kind == UnitPart::Kind::Head) record(1 + p.head, 1, r, took, false, now);
      });
      if (d.kind == UnitKind::Coarse && d.head >= 0 &&
          d.head < static_cast<int>(model_.heads.size())) {
        const int c = static_cast<int>(planned_) + d.head;
        const Duration own = p50(c, 1);
        if (own > Duration{0})
          record(c, 1, static_cast<double>(took.count()) / static_cast<double>(own.count()), took,
                 true, now);
      }
      return;
    }
    case UnitKind::Plain:
      return;
  }
}

bool OnlineCosts::update(TimePoint now) {
  if (!opt_.follow || !fresh_) return false;
  if (last_update_ != kNever && now - last_update_ < opt_.interval) return false;
  last_update_ = now;
  fresh_ = false;
  bool moved = false;
  for (std::size_t i = 0; i < planned_; ++i) {
    Unit& u = units_[i];
    u.next_applied = u.applied;
    const std::size_t size = u.ring.size();
    if (size < static_cast<std::size_t>(opt_.min_samples)) continue;
    // The samples that count, newest first (the ring is in time order from `next`): those
    // within the window, or the newest min_samples, read in place. Only on evidence: where
    // the plan is right a run is as likely to take more than its median as less. A sign test
    // over them (z of the count above the planned median) keeps a wide but right profile from
    // moving the plan on a few slow runs; most updates end there, allocating nothing.
    std::size_t n = 0;
    int above = 0;
    for (std::size_t idx = (u.next == 0 ? size : u.next) - 1; n < size;
         idx = idx == 0 ? size - 1 : idx - 1) {
      const Sample& s = u.ring[idx];
      if (n >= static_cast<std::size_t>(opt_.min_samples) && now - s.at > opt_.window) break;
      above += s.ratio > u.applied[static_cast<std::size_t>(s.batch - 1)] ? 1 : 0;
      ++n;
    }
    const double half = static_cast<double>(n) / 2.0;
    const double z =
        (static_cast<double>(above) - half) / (0.5 * std::sqrt(static_cast<double>(n)));
    if (std::abs(z) < opt_.evidence) continue;
    std::vector<Sample> recent;
    for (std::size_t k = 0, idx = (u.next == 0 ? size : u.next) - 1; k < n;
         ++k, idx = idx == 0 ? size - 1 : idx - 1)
      recent.push_back(u.ring[idx]);
    scratch_.clear();
    for (const Sample& s : recent) scratch_.push_back(s.ratio);
    const double unit_factor = median_of(scratch_);
    for (std::size_t b = 0; b < u.applied.size(); ++b) {
      scratch_.clear();
      for (const Sample& s : recent)
        if (s.batch == b + 1) scratch_.push_back(s.ratio);
      const double f =
          static_cast<int>(scratch_.size()) >= opt_.min_samples ? median_of(scratch_) : unit_factor;
      if (std::abs(f / u.applied[b] - 1.0) > opt_.threshold) {
        u.next_applied[b] = f;
        moved = true;
      }
    }
  }
  if (!moved) return false;
  if (!changed_) {
    plan_ = base_;
    plan_.calibration.reset();  // the scheduler reads the units only
    changed_ = true;
  }
  for (std::size_t i = 0; i < planned_; ++i) {
    Unit& u = units_[i];
    if (u.prof == nullptr) continue;
    u.applied = u.next_applied;
    UnitProfile& p = plan_.units.at(u.name);
    for (std::size_t b = 0; b < p.by_batch.size() && b < u.applied.size(); ++b)
      p.by_batch[b] = u.prof->by_batch[b].scaled(u.applied[b]);
  }
  ++changes_;
  return true;
}

Duration OnlineCosts::median_at(int unit, int batch) const {
  std::vector<float> k =
      units_[static_cast<std::size_t>(unit)].kept[static_cast<std::size_t>(batch - 1)];
  if (k.empty()) return Duration{0};
  return Duration{static_cast<std::int64_t>(std::llround(median_of(k) * 1e6))};
}

std::vector<UnitCostFigures> OnlineCosts::figures() const {
  std::vector<UnitCostFigures> out;
  for (std::size_t i = 0; i < units_.size(); ++i) {
    const Unit& u = units_[i];
    if (u.prof == nullptr) continue;
    for (std::size_t b = 0; b < u.runs.size(); ++b) {
      if (u.runs[b] == 0 && u.applied[b] == 1.0) continue;
      UnitCostFigures f;
      f.unit = u.name;
      f.batch = static_cast<int>(b + 1);
      f.runs = u.runs[b];
      f.profile_mean = u.prof->by_batch[b].mean;
      f.profile_p50 = u.prof->by_batch[b].p50;
      if (f.runs > 0) {
        f.run_mean = u.total[b] / f.runs;
        f.run_p50 = median_at(static_cast<int>(i), f.batch);
      }
      f.factor = u.applied[b];
      out.push_back(f);
    }
  }
  return out;
}

}  // namespace red
