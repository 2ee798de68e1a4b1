#pragma once
/// \file
/// Refinement (docs/DESIGN.md, "Refinement"): an operation's DAG as the policy sees it. Coarse: one
/// unit per node (encoder + head run back to back). Fine: every inference node v becomes e_v
/// (encoder on v's frame, always a source) and d_v (its head). Mono: the whole job as one unit.
/// Also the static part of docs/DESIGN.md, "Intermediate deadlines": heights, level costs and
/// static intermediate deadlines, computed once per graph version and cached.

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "red/core/time.hpp"
#include "red/scenario/scenario.hpp"

namespace red {

struct Profile;

/// How an operation's nodes become schedulable units.
enum class GraphMode : std::uint8_t { Coarse, Fine, Mono };

/// How a job's end-to-end deadline becomes intermediate deadlines (docs/DESIGN.md, "Intermediate
/// deadlines" and "Policies").
enum class DeadlineMode : std::uint8_t {
  None,          ///< no deadlines: release order (fifo)
  EndToEnd,      ///< every unit gets the job's end-to-end deadline (coarse edf)
  Proportional,  ///< D_h proportional to level cost L_h (the paper's rule)
  Equal,         ///< D_h = D / (K + 1)
};

/// What a unit runs.
enum class UnitKind : std::uint8_t {
  Encoder,  ///< the shared encoder on one frame (fine graph)
  Head,     ///< one head on encoder features (fine graph)
  Coarse,   ///< encoder then head, one node (coarse graph)
  Mono,     ///< the encoder once per sensor and every head the job needs, one unit
  Plain,    ///< a plain compute node with its own cost
};

const char* to_string(UnitKind k) noexcept;
const char* to_string(GraphMode m) noexcept;
const char* to_string(DeadlineMode m) noexcept;

/// One schedulable unit of a refined graph.
struct RefinedUnit {
  UnitKind kind = UnitKind::Plain;
  int node = -1;    ///< the node it belongs to (-1 for Mono)
  int head = -1;    ///< model head (Head, Coarse), else -1
  int sensor = -1;  ///< sensor whose frame it reads (Encoder, Head, Coarse), else -1
  std::vector<int> preds;
  std::vector<int> succs;
  int height = 0;
  Duration estimate{0};  ///< c(x) under the scheduler's EstimateKind
  /// c(x) under every EstimateKind, indexed by it (overload checks use an optimistic one).
  std::array<Duration, 4> costs{};
  /// Longest path from this unit (included) to a sink, under every EstimateKind.
  std::array<Duration, 4> tail{};
  /// The least mean time a run of it takes in any batch (CostModel::least_encoder/least_head: a
  /// batch of b may cost less than a run alone), and the longest path from it to a sink at those
  /// times: the optimistic remaining path that hopeless aborts judge by.
  Duration least{0};
  Duration least_tail{0};
  std::vector<int> produces;  ///< nodes whose output this unit produces (empty: Encoder)
};

/// An operation's graph after refinement, with cached static deadline data.
struct RefinedGraph {
  GraphMode mode = GraphMode::Coarse;
  std::shared_ptr<const OperationSpec> spec;
  int operation = -1;
  std::vector<RefinedUnit> units;    ///< topological order: preds before succs
  int levels = 0;                    ///< K + 1
  std::vector<Duration> level_cost;  ///< static L_h
  /// Weight of height h in proportional (re-)assignment: L_h, or the per-node override
  /// when a node at that height has one (docs/DESIGN.md, "Intermediate deadlines" overrides).
  std::vector<Duration> override_budget;  ///< per height; 0 = none
  /// Static relative intermediate deadline of height h: Σ_{k ≤ h} D_k.
  std::vector<Duration> static_offset;
  Duration deadline{0};           ///< relative end-to-end deadline D (resolved)
  Duration critical_path{0};      ///< longest estimated path through the units
  std::vector<int> sources;       ///< units without predecessors
  std::vector<int> head_sources;  ///< non-encoder units whose only preds are encoders
  /// Number of distinct sensors read (for Mono cost).
  std::vector<int> sensors;
};

/// One piece of work a unit runs: what each caller prices (a mean, a draw, a bound...) and sums.
/// A unit's parts are listed once, here, by for_each_part; a new UnitKind is added there.
struct UnitPart {
  enum class Kind : std::uint8_t {
    Encoder,  ///< the shared encoder on one sensor's frame
    Head,     ///< one model head on encoder features
    Plain,    ///< a plain compute node with its own cost
  };
  Kind kind = Kind::Plain;
  /// The node it computes (Head, Plain) or encodes for (the Encoder of an Encoder or Coarse
  /// unit); -1 for a Mono unit's encoders, which serve every node on their sensor.
  int node = -1;
  int head = -1;                    ///< Head: index into ModelSpec::heads, else -1
  int sensor = -1;                  ///< Encoder, Head: the sensor whose frame it reads, else -1
  const PlainCost* cost = nullptr;  ///< Plain: the node's cost (null if the node has none)
};

/// Calls `f(const UnitPart&)` for each part of unit `u` of graph `g`, in this order:
/// - Encoder: the encoder on the unit's sensor;
/// - Head: the unit's head;
/// - Coarse: the encoder on the node's sensor, then the node's head;
/// - Plain: the plain node;
/// - Mono: the encoder once per sensor the operation reads (RefinedGraph::sensors, in order),
///   then every node of the operation in index order, a Head or a Plain part.
/// Callers sum in this order; the Duration sums are exact, so the order fixes nothing but
/// the order of any draws a caller makes.
template <class F>
void for_each_part(const RefinedGraph& g, const RefinedUnit& u, F&& f) {
  using K = UnitPart::Kind;
  const auto plain = [&](int v) {
    const NodeSpec& n = g.spec->nodes[static_cast<std::size_t>(v)];
    return UnitPart{K::Plain, v, -1, -1, n.cost ? &*n.cost : nullptr};
  };
  switch (u.kind) {
    case UnitKind::Encoder:
      f(UnitPart{K::Encoder, u.node, -1, u.sensor, nullptr});
      return;
    case UnitKind::Head:
      f(UnitPart{K::Head, u.node, u.head, u.sensor, nullptr});
      return;
    case UnitKind::Coarse:
      f(UnitPart{K::Encoder, u.node, -1, u.sensor, nullptr});
      f(UnitPart{K::Head, u.node, u.head, u.sensor, nullptr});
      return;
    case UnitKind::Plain:
      f(plain(u.node));
      return;
    case UnitKind::Mono:
      for (int sensor : g.sensors) f(UnitPart{K::Encoder, -1, -1, sensor, nullptr});
      for (std::size_t v = 0; v < g.spec->nodes.size(); ++v) {
        const NodeSpec& n = g.spec->nodes[v];
        f(n.is_plain() ? plain(static_cast<int>(v))
                       : UnitPart{K::Head, static_cast<int>(v), n.head, n.sensor, nullptr});
      }
      return;
  }
}

/// The parts of unit `u` of graph `g`, in for_each_part's order.
std::vector<UnitPart> unit_parts(const RefinedGraph& g, const RefinedUnit& u);

/// Cost model used by refinement: unit estimates from a profile.
struct CostModel {
  const Profile* profile = nullptr;
  const ModelSpec* model = nullptr;
  EstimateKind estimate = EstimateKind::P99;

  [[nodiscard]] Duration encoder() const;
  [[nodiscard]] Duration head(int h) const;
  /// The least mean cost over the profile's batch sizes of one encoder run, or of head h.
  [[nodiscard]] Duration least_encoder() const;
  [[nodiscard]] Duration least_head(int h) const;
  /// The same model with another estimate kind.
  [[nodiscard]] CostModel with(EstimateKind k) const {
    CostModel c = *this;
    c.estimate = k;
    return c;
  }
  [[nodiscard]] static Duration plain(const PlainCost& c, EstimateKind k);
};

/// Options of refinement and static assignment.
struct RefineOptions {
  GraphMode mode = GraphMode::Fine;
  DeadlineMode deadlines = DeadlineMode::Proportional;
  LevelCost level_cost = LevelCost::Max;
  /// The relative end-to-end deadline when it was resolved before (a graph priced again at
  /// other costs keeps the deadline its operation was given); 0: resolve it from the costs.
  Duration deadline{0};
};

/// The coarse critical path of an operation under a cost model (used to resolve
/// `deadline_ms: {critical_path_x: k}`).
Duration coarse_critical_path(const OperationSpec& op, const CostModel& costs);

/// The shortest time a job of `op` can take alone, on any graph: on the fine graph (a node starts
/// after its frame's encoder run and its predecessors), every unit at its least mean cost over the
/// profile's batch sizes (least_encoder, least_head), plain nodes at their mean.
Duration least_critical_path(const OperationSpec& op, const CostModel& costs);

/// Resolves an operation's relative end-to-end deadline.
Duration resolve_deadline(const OperationSpec& op, const CostModel& costs);

/// Refines one operation snapshot (docs/DESIGN.md, "Refinement") and computes heights and static
/// deadlines (docs/DESIGN.md, "Intermediate deadlines").
std::shared_ptr<const RefinedGraph> refine(std::shared_ptr<const OperationSpec> op, int operation,
                                           const CostModel& costs, const RefineOptions& opt);

// ---- The deadline split --------------------------------------------------------------------
// docs/DESIGN.md, "Intermediate deadlines": how a job's end-to-end deadline becomes the deadlines
// of its heights. The one rule, read by refinement (static offsets, split_budget), the scheduler
// (unit_deadline, re-assignment's shares) and the nptest export (priorities).

/// True when `m` splits the budget over the heights (proportional, equal). Under none every
/// height's deadline is the job's release (release order); under e2e the job's deadline.
constexpr bool splits_budget(DeadlineMode m) noexcept {
  return m == DeadlineMode::Proportional || m == DeadlineMode::Equal;
}

/// The absolute deadline of a height of a job released at `release`, due at `end`, under mode
/// `m`: `split()` gives it where `m` splits the budget (static offsets or re-assignment).
template <class Split>
TimePoint height_deadline(DeadlineMode m, TimePoint release, TimePoint end, Split&& split) {
  switch (m) {
    case DeadlineMode::None:
      return release;
    case DeadlineMode::EndToEnd:
      return end;
    case DeadlineMode::Proportional:
    case DeadlineMode::Equal:
      break;
  }
  return split();
}

/// A height's weight in the split: the per-node override budget where one of its nodes has one,
/// else `level`, its level cost (static, or what is left of it at a re-assignment).
inline Duration split_weight(const RefinedGraph& g, std::size_t h, Duration level) {
  return g.override_budget[h] > Duration{0} ? g.override_budget[h] : level;
}

/// The split's cumulative shares over `levels` heights: f(h, counts, cum, denom) for every
/// height in order, `counts` = has(h) (the height still has work), `cum` the weight of the
/// heights with work up to h and `denom` that of all of them: weight(h) each, or 1 each under
/// Equal or where none weighs anything.
template <class Weight, class Has, class F>
void for_each_share(DeadlineMode m, std::size_t levels, Weight&& weight, Has&& has, F&& f) {
  std::int64_t total = 0;
  std::int64_t n = 0;
  for (std::size_t h = 0; h < levels; ++h) {
    if (!has(h)) continue;
    ++n;
    total += weight(h).count();
  }
  const bool equal = m == DeadlineMode::Equal || total <= 0;
  const std::int64_t denom = equal ? n : total;
  std::int64_t cum = 0;
  for (std::size_t h = 0; h < levels; ++h) {
    const bool counts = has(h);
    if (counts) cum += equal ? 1 : weight(h).count();
    f(h, counts, cum, denom);
  }
}

/// Static proportional/equal split of `budget` over heights with weights `weights`
/// (zero-weight heights get nothing under Proportional unless all are zero).
/// Returns cumulative offsets (size = weights.size()).
std::vector<Duration> split_budget(Duration budget, const std::vector<Duration>& weights,
                                   DeadlineMode mode);

}  // namespace red
