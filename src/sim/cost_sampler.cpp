#include "red/sim/cost_sampler.hpp"

#include <algorithm>
#include <cmath>

#include "red/core/assert.hpp"
#include "red/core/rng.hpp"

namespace red {

namespace {
constexpr std::uint64_t kEncoderTag = 0x454e43;  // "ENC"
constexpr std::uint64_t kHeadTag = 0x484541;     // "HEA"
constexpr std::uint64_t kPlainTag = 0x504c41;    // "PLA"
}  // namespace

LatencyStats plain_stats(const PlainCost& c) {
  LatencyStats s;
  const Duration spread = c.p99 - c.mean;
  s.mean = c.mean;
  s.p50 = c.mean;
  s.p95 = c.mean + spread * 6 / 10;
  s.p99 = c.p99;
  s.max = c.p99 + spread * 15 / 100;
  s.min = std::max(Duration{0}, c.mean - spread / 2);
  return s;
}

CostSampler::CostSampler(const Scenario& s, const Profile& p, std::uint64_t seed, double slowdown)
    : scenario_(s), seed_(seed), slowdown_(slowdown) {
  encoder_ = p.find("encoder");
  for (const std::string& h : s.model.heads) heads_.push_back(p.find("head/" + h));
  if (p.calibration) {
    // The calibration ran under its own background load: only the difference slows units.
    cal_ = &*p.calibration;
    cal_slowdown_ = slowdown / (1.0 + cal_->interference);
    cal_encoder_ = tables("encoder");
    for (const std::string& h : s.model.heads) {
      cal_heads_.push_back(tables("head/" + h));
      cal_coarse_.push_back(tables("coarse/" + h));
    }
  }
}

const CostSampler::Tables* CostSampler::tables(const std::string& unit) const {
  const auto it = cal_->residual.find(unit);
  return it == cal_->residual.end() ? nullptr : &it->second;
}

const std::vector<Duration>* CostSampler::table_at(const Tables* t, int batch) {
  if (t == nullptr || batch < 1 || batch > static_cast<int>(t->size())) return nullptr;
  const std::vector<Duration>& v = (*t)[static_cast<std::size_t>(batch - 1)];
  return v.empty() ? nullptr : &v;
}

double CostSampler::encoder_u(int sensor, std::uint64_t frame) const {
  return unit_uniform(hash_combine(
      hash_combine(hash_combine(seed_, kEncoderTag), static_cast<std::uint64_t>(sensor)), frame));
}

double CostSampler::head_u(int op, std::uint64_t seq, int node) const {
  std::uint64_t k = hash_combine(seed_, kHeadTag);
  k = hash_combine(k, static_cast<std::uint64_t>(op));
  k = hash_combine(k, seq);
  k = hash_combine(k, static_cast<std::uint64_t>(node));
  return unit_uniform(k);
}

Duration CostSampler::draw(const UnitProfile& u, const Tables* t, int batch, double u01) {
  if (const std::vector<Duration>* v = table_at(t, batch)) return table_quantile(*v, u01);
  return u.at(batch).quantile(u01);
}

Duration CostSampler::scaled(Duration d) const {
  if (slowdown_ == 1.0 || cal_ != nullptr) return d;  // calibrated: slowed in sample()
  return scaled_by(d, slowdown_);
}

Duration CostSampler::encoder(int sensor, std::uint64_t frame, int batch) const {
  RED_ASSERT(encoder_ != nullptr);
  const double u = encoder_u(sensor, frame);
  if (cal_ != nullptr) return draw(*encoder_, cal_encoder_, batch, u);
  return scaled(encoder_->at(batch).quantile(u));
}

Duration CostSampler::head(int h, int op, std::uint64_t seq, int node, int batch) const {
  const UnitProfile* p = heads_[static_cast<std::size_t>(h)];
  RED_ASSERT(p != nullptr);
  const double u = head_u(op, seq, node);
  if (cal_ != nullptr) return draw(*p, cal_heads_[static_cast<std::size_t>(h)], batch, u);
  return scaled(p->at(batch).quantile(u));
}

Duration CostSampler::plain(const PlainCost& c, int op, std::uint64_t seq, int node) const {
  if (c.p99 == c.mean) return scaled(c.mean);
  std::uint64_t k = hash_combine(seed_, kPlainTag);
  k = hash_combine(k, static_cast<std::uint64_t>(op));
  k = hash_combine(k, seq);
  k = hash_combine(k, static_cast<std::uint64_t>(node));
  return scaled(plain_stats(c).quantile(unit_uniform(k)));
}

Duration CostSampler::sample(const Dispatch& d, TimePoint start, int busy_others) const {
  if (cal_ == nullptr) return uncalibrated(d);
  // Calibrated (docs/FIDELITY.md): the in-run residual of the unit as a whole where the
  // calibration measured it (coarse and mono units too), times the machine's time factor
  // at the start, the lane factor and any background load beyond the calibration's.
  Duration base = Duration{-1};
  const Member& m = d.members.front();
  const RefinedGraph& g = *m.graph;
  const RefinedUnit& ru = g.units[static_cast<std::size_t>(m.unit)];
  if (d.kind == UnitKind::Coarse) {
    if (const auto* t = table_at(cal_coarse_[static_cast<std::size_t>(ru.head)], 1))
      base = table_quantile(*t, encoder_u(ru.sensor, m.frame));
  } else if (d.kind == UnitKind::Mono && !g.sensors.empty()) {
    // One lookup per job: mono units are named by their operation.
    if (const auto* t = table_at(tables("mono/" + g.spec->name), 1))
      base = table_quantile(*t, encoder_u(g.sensors.front(), m.frame));
  }
  if (base < Duration{0}) base = uncalibrated(d);
  const std::size_t k =
      std::min(static_cast<std::size_t>(std::max(0, busy_others)), cal_->lane_factors.size() - 1);
  const double f = cal_->factor_at(start, seed_) * cal_->lane_factors[k] * cal_slowdown_;
  return scaled_by(base, f);
}

Duration profiled_cost(const Dispatch& d, const UnitProfile* encoder,
                       const std::vector<const UnitProfile*>& heads, Duration LatencyStats::*stat) {
  auto at = [stat](const UnitProfile* u, int batch) {
    if (u == nullptr || u->max_batch() == 0) return Duration{0};
    const Duration p = u->at(batch).*stat;
    return batch > u->max_batch() ? p * batch / u->max_batch() : p;
  };
  auto head = [&](int h, int batch) {
    return h >= 0 && static_cast<std::size_t>(h) < heads.size()
               ? at(heads[static_cast<std::size_t>(h)], batch)
               : Duration{0};
  };
  const Member& m = d.members.front();
  const RefinedGraph& g = *m.graph;
  const RefinedUnit& u = g.units[static_cast<std::size_t>(m.unit)];
  // A run of `batch` tasks prices each part at that batch; a mono unit is never batched.
  const int batch = d.kind == UnitKind::Mono ? 1 : d.batch;
  Duration t{0};
  for_each_part(g, u, [&](const UnitPart& p) {
    switch (p.kind) {
      case UnitPart::Kind::Encoder:
        t += at(encoder, batch);
        break;
      case UnitPart::Kind::Head:
        t += head(p.head, batch);
        break;
      case UnitPart::Kind::Plain:
        t += p.cost != nullptr ? plain_stats(*p.cost).*stat * batch : Duration{0};
        break;
    }
  });
  return t;
}

Duration CostSampler::uncalibrated(const Dispatch& d) const {
  RED_ASSERT(!d.members.empty());
  const Member& m = d.members.front();
  const RefinedGraph& g = *m.graph;
  const RefinedUnit& ru = g.units[static_cast<std::size_t>(m.unit)];
  // One run of an encoder or a head encodes or reads `batch` frames; the first frame's draw picks
  // the quantile. A mono unit draws its encoder once per sensor, with the CRN key the job's frame
  // of the first sensor, else the job.
  const int batch = d.kind == UnitKind::Encoder || d.kind == UnitKind::Head ? d.batch : 1;
  Duration t{0};
  bool first = true;
  for_each_part(g, ru, [&](const UnitPart& p) {
    switch (p.kind) {
      case UnitPart::Kind::Encoder:
        t += first ? encoder(p.sensor, m.frame, batch)
                   : encoder(p.sensor, m.job_seq * 131 + static_cast<std::uint64_t>(p.sensor));
        first = false;
        break;
      case UnitPart::Kind::Head:
        t += head(p.head, m.operation, m.job_seq, p.node, batch);
        break;
      case UnitPart::Kind::Plain:
        t += plain(*p.cost, m.operation, m.job_seq, p.node);
        break;
    }
  });
  return t;
}

}  // namespace red
