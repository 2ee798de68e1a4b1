// A unit's parts (for_each_part, unit_parts): what each UnitKind runs, listed once in the graph
// layer for every caller that prices a unit (refinement's estimates, the simulator's draws and
// profiled costs, the runtime's watchdog, the nptest export). Checked over every UnitKind on one
// operation with two sensors, a plain node and nodes whose index order differs from their
// topological order, and against the estimates refinement stores.

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "../support/harness.hpp"
#include "red/graph/refine.hpp"
#include "red/profile/profile.hpp"

namespace red {
namespace {

using Kind = UnitPart::Kind;

// Node index order F, P, R, C; topological order R, F, P, C (R feeds F). Sensors read: front
// (F, C), rear (R), in node index order front first.
constexpr const char* kScenario = R"(name: parts
duration_s: 1
model: {builtin: mimonet, heads: [lane, seg, steer, det]}
sensors:
  front: {rate_hz: 10}
  rear: {rate_hz: 10}
operations:
  - name: fuse
    trigger: front
    deadline_ms: 150
    nodes:
      F: {head: seg, sensor: front}
      P: {cost_ms: 1.5}
      R: {head: det, sensor: rear}
      C: {head: steer, sensor: front}
    edges: [[R, F], [F, P], [P, C]]
)";

constexpr int kF = 0, kP = 1, kR = 2, kC = 3;  // node indices
constexpr int kSeg = 1, kSteer = 2, kDet = 3;  // head indices
constexpr int kFront = 0, kRear = 1;           // sensor indices

struct Expect {
  Kind kind;
  int node, head, sensor;
  bool has_cost;
};

void expect_parts(const RefinedGraph& g, const RefinedUnit& u, const std::vector<Expect>& want) {
  const std::vector<UnitPart> got = unit_parts(g, u);
  ASSERT_EQ(got.size(), want.size()) << to_string(u.kind) << " unit of node " << u.node;
  for (std::size_t i = 0; i < got.size(); ++i) {
    SCOPED_TRACE(std::string(to_string(u.kind)) + " unit, part " + std::to_string(i));
    EXPECT_EQ(got[i].kind, want[i].kind);
    EXPECT_EQ(got[i].node, want[i].node);
    EXPECT_EQ(got[i].head, want[i].head);
    EXPECT_EQ(got[i].sensor, want[i].sensor);
    EXPECT_EQ(got[i].cost != nullptr, want[i].has_cost);
    if (want[i].has_cost) {
      EXPECT_EQ(got[i].cost, &*g.spec->nodes[static_cast<std::size_t>(want[i].node)].cost);
    }
  }
}

/// The parts an Encoder, Head, Coarse or Plain unit of node `v` must have.
std::vector<Expect> expected_parts(UnitKind kind, int v) {
  switch (v) {
    case kF:
    case kC: {
      const int head = v == kF ? kSeg : kSteer;
      if (kind == UnitKind::Encoder) return {{Kind::Encoder, v, -1, kFront, false}};
      if (kind == UnitKind::Head) return {{Kind::Head, v, head, kFront, false}};
      return {{Kind::Encoder, v, -1, kFront, false}, {Kind::Head, v, head, kFront, false}};
    }
    case kR:
      if (kind == UnitKind::Encoder) return {{Kind::Encoder, v, -1, kRear, false}};
      if (kind == UnitKind::Head) return {{Kind::Head, v, kDet, kRear, false}};
      return {{Kind::Encoder, v, -1, kRear, false}, {Kind::Head, v, kDet, kRear, false}};
    default:
      return {{Kind::Plain, kP, -1, -1, true}};
  }
}

class UnitParts : public testing::Test {
 protected:
  std::shared_ptr<const RefinedGraph> refined(GraphMode mode) const {
    const CostModel costs{&profile_, &scenario_.model, scenario_.scheduler.estimate};
    return refine(scenario_.initial.at(0), 0, costs,
                  {mode, DeadlineMode::Proportional, LevelCost::Max});
  }

  Scenario scenario_ = test::parse(kScenario);
  Profile profile_ = default_profile();
};

TEST_F(UnitParts, FineGraphEncoderHeadAndPlainUnits) {
  const auto g = refined(GraphMode::Fine);
  int encoders = 0, heads = 0, plains = 0;
  for (const RefinedUnit& u : g->units) {
    ASSERT_TRUE(u.kind == UnitKind::Encoder || u.kind == UnitKind::Head ||
                u.kind == UnitKind::Plain)
        << to_string(u.kind);
    encoders += u.kind == UnitKind::Encoder ? 1 : 0;
    heads += u.kind == UnitKind::Head ? 1 : 0;
    plains += u.kind == UnitKind::Plain ? 1 : 0;
    expect_parts(*g, u, expected_parts(u.kind, u.node));
  }
  EXPECT_EQ(encoders, 3);
  EXPECT_EQ(heads, 3);
  EXPECT_EQ(plains, 1);
}

TEST_F(UnitParts, CoarseGraphCoarseUnitIsEncoderThenHead) {
  const auto g = refined(GraphMode::Coarse);
  int coarse = 0;
  for (const RefinedUnit& u : g->units) {
    ASSERT_TRUE(u.kind == UnitKind::Coarse || u.kind == UnitKind::Plain) << to_string(u.kind);
    coarse += u.kind == UnitKind::Coarse ? 1 : 0;
    expect_parts(*g, u, expected_parts(u.kind, u.node));
  }
  EXPECT_EQ(coarse, 3);
}

TEST_F(UnitParts, MonoUnitIsOneEncoderPerSensorThenEveryNodeInIndexOrder) {
  const auto g = refined(GraphMode::Mono);
  ASSERT_EQ(g->units.size(), 1u);
  ASSERT_EQ(g->units[0].kind, UnitKind::Mono);
  expect_parts(*g, g->units[0],
               {{Kind::Encoder, -1, -1, kFront, false},
                {Kind::Encoder, -1, -1, kRear, false},
                {Kind::Head, kF, kSeg, kFront, false},
                {Kind::Plain, kP, -1, -1, true},
                {Kind::Head, kR, kDet, kRear, false},
                {Kind::Head, kC, kSteer, kFront, false}});
}

TEST_F(UnitParts, RefinedEstimatesAreTheSumOfTheirPartsUnderEveryEstimateKind) {
  const CostModel costs{&profile_, &scenario_.model, scenario_.scheduler.estimate};
  for (GraphMode mode : {GraphMode::Fine, GraphMode::Coarse, GraphMode::Mono}) {
    SCOPED_TRACE(to_string(mode));
    const auto g = refined(mode);
    for (const RefinedUnit& u : g->units) {
      for (int k = 0; k < 4; ++k) {
        const CostModel ck = costs.with(static_cast<EstimateKind>(k));
        Duration sum{0};
        for (const UnitPart& p : unit_parts(*g, u))
          sum += p.kind == Kind::Encoder ? ck.encoder()
                 : p.kind == Kind::Head  ? ck.head(p.head)
                                         : CostModel::plain(*p.cost, ck.estimate);
        EXPECT_EQ(u.costs[static_cast<std::size_t>(k)], sum) << to_string(u.kind);
        EXPECT_GT(sum, Duration{0});
      }
      EXPECT_EQ(u.estimate, u.costs[static_cast<std::size_t>(scenario_.scheduler.estimate)]);
    }
  }
}

}  // namespace
}  // namespace red
