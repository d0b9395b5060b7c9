// The collapse engine's contract with cost models (what an image-driven cost relies on): the
// initial fill comes in large batches, every later batch holds exactly the edges the last
// collapse invalidated (all touching the survivor, or its ring with invalidation_ring = 2), both
// directions of an edge are priced under endpoint placement, the survivor stays put when
// endpoint_only, and placeAttributes/onCollapse run once per applied collapse. With pass ordering
// (the quadric mode's), one evaluate() per pass and no overlapping collapses within a pass.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cfenv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <optional>
#include <set>
#include <stdexcept>
#include <thread>

#include "mesh/collapse_engine.hpp"
#include "mesh/quadric.hpp"
#include "mesh/run_both.hpp"
#include "mesh/second_core.hpp"
#include "mesh_test_meshes.hpp"

namespace duolod {
namespace {

// Prices a collapse by the length of its edge; remembers every call.
class RecordingModel : public mesh::CostModel {
 public:
  void begin(const mesh::EngineState& state) override { begun = state.positions.size(); }
  void evaluate(const mesh::EngineState& state, std::span<mesh::CandidateCollapse> batch) override {
    batches.emplace_back(batch.begin(), batch.end());
    for (auto& c : batch) {
      mesh::Vec3d d = state.positions[c.to] - state.positions[c.from];
      c.cost = c.error = std::sqrt(mesh::dot(d, d));
      c.position = state.positions[c.to];
    }
  }
  void placeAttributes(const mesh::EngineState&, const mesh::CandidateCollapse&,
                       std::span<float>) override {
    ++placed;
  }
  void onCollapse(const mesh::EngineState& state, const mesh::AppliedCollapse& applied) override {
    applied_collapses.push_back(applied);
    live_after.push_back(state.live_triangles);
    EXPECT_FALSE(state.position_alive[applied.candidate.from]);
    EXPECT_TRUE(state.position_alive[applied.candidate.to]);
  }

  size_t begun = 0;
  size_t placed = 0;
  std::vector<std::vector<mesh::CandidateCollapse>> batches;
  std::vector<mesh::AppliedCollapse> applied_collapses;
  std::vector<size_t> live_after;
};

// The positions adjacent to p in the current state.
std::set<uint32_t> neighbours(const mesh::EngineState& state, uint32_t p) {
  std::set<uint32_t> out;
  state.forEachCorner(p, [&](uint32_t c) {
    uint32_t t = c / 3;
    for (int k = 0; k < 3; ++k)
      if (state.cornerPosition(t * 3 + k) != p) out.insert(state.cornerPosition(t * 3 + k));
  });
  return out;
}

// Index of the first batch after the initial fill, which prices `fill_candidates` candidates.
size_t firstCollapseBatch(const RecordingModel& model, size_t fill_candidates) {
  size_t i = 0, filled = 0;
  while (i < model.batches.size() && filled < fill_candidates) filled += model.batches[i++].size();
  EXPECT_EQ(filled, fill_candidates);
  return i;
}

TEST(CollapseEngine, BatchesAreTheInvalidatedEdges) {
  core::Mesh sphere = test::icosphere(3, 1.0f, test::lumps);  // 642 positions, 1920 edges
  core::computeNormals(sphere);  // attributes present, so placeAttributes is called
  RecordingModel model;
  mesh::EngineOptions options{.target_triangles = 600, .endpoint_only = true, .batch_size = 256};
  auto result = mesh::runCollapseEngine(mesh::prepareMesh(sphere), model, options);
  EXPECT_EQ(model.begun, sphere.vertexCount());
  EXPECT_EQ(result.mesh.triangleCount(), 600u);
  ASSERT_EQ(model.applied_collapses.size(), result.stats.collapses);
  EXPECT_EQ(model.placed, result.stats.collapses);

  // Initial fill: both directions of all 1920 edges, in batches of at least 256 (but the last).
  const size_t fill = firstCollapseBatch(model, 2 * 1920);
  std::set<std::pair<uint32_t, uint32_t>> directed;
  for (size_t i = 0; i < fill; ++i) {
    if (i + 1 < fill) {
      EXPECT_GE(model.batches[i].size(), 256u);
    }
    for (const auto& c : model.batches[i]) directed.insert({c.from, c.to});
  }
  EXPECT_EQ(directed.size(), 2u * 1920u);
  for (auto [a, b] : directed) EXPECT_TRUE(directed.count({b, a}));

  // Then one batch per collapse, every candidate touching that collapse's survivor, and covering
  // all of its edges (both directions).
  ASSERT_EQ(model.batches.size() - fill, model.applied_collapses.size());
  for (size_t k = 0; k < model.applied_collapses.size(); ++k) {
    const auto& batch = model.batches[fill + k];
    uint32_t survivor = model.applied_collapses[k].candidate.to;
    std::set<uint32_t> others;
    for (const auto& c : batch) {
      EXPECT_TRUE(c.from == survivor || c.to == survivor);
      EXPECT_TRUE(c.endpoint_only);
      others.insert(c.from == survivor ? c.to : c.from);
    }
    EXPECT_EQ(batch.size(), 2 * others.size());
  }
  // Endpoint placement: every survivor kept an input position.
  std::set<std::array<float, 3>> input;
  for (auto p : sphere.positions) input.insert({p.x, p.y, p.z});
  for (auto p : result.mesh.positions) EXPECT_TRUE(input.count({p.x, p.y, p.z}));
}

// With ring 2 the batch after a collapse also re-prices the edges around the survivor's
// neighbours (a rendered cost changes there too).
TEST(CollapseEngine, RingTwoInvalidatesTheNeighbours) {
  core::Mesh sphere = test::icosphere(2, 1.0f, test::lumps);  // 162 positions, 480 edges
  RecordingModel model;
  mesh::EngineOptions options{.target_triangles = 200, .invalidation_ring = 2};
  auto result = mesh::runCollapseEngine(mesh::prepareMesh(sphere), model, options);
  EXPECT_EQ(result.mesh.triangleCount(), 200u);
  // Optimal placement: one candidate per edge between free vertices.
  const size_t fill = firstCollapseBatch(model, 480);
  ASSERT_EQ(model.batches.size() - fill, model.applied_collapses.size());
  size_t beyond = 0;
  for (size_t k = 0; k < model.applied_collapses.size(); ++k) {
    uint32_t survivor = model.applied_collapses[k].candidate.to;
    for (const auto& c : model.batches[fill + k]) beyond += c.from != survivor && c.to != survivor;
  }
  EXPECT_GT(beyond, model.applied_collapses.size());
}

// The state a model sees is consistent: the live triangle count matches the triangles reachable
// through the corner lists, and removed positions have none.
TEST(CollapseEngine, StateStaysConsistent) {
  core::Mesh grid = test::seamGrid(12, [](float x, float y) { return 0.1f * x * y; });
  class CheckingModel : public RecordingModel {
   public:
    void onCollapse(const mesh::EngineState& state, const mesh::AppliedCollapse& applied) override {
      RecordingModel::onCollapse(state, applied);
      size_t corners = 0;
      for (uint32_t p = 0; p < state.positions.size(); ++p)
        if (state.position_alive[p]) state.forEachCorner(p, [&](uint32_t) { ++corners; });
      EXPECT_EQ(corners, state.live_triangles * 3);
      EXPECT_TRUE(neighbours(state, applied.candidate.from).empty());
    }
  } model;
  auto result = mesh::runCollapseEngine(mesh::prepareMesh(grid), model, {.target_triangles = 40});
  EXPECT_LE(result.mesh.triangleCount(), 60u);
  EXPECT_GT(model.applied_collapses.size(), 100u);
}

// Pass ordering: each evaluate() call prices one pass; within a pass no two applied collapses
// share an endpoint (a second one would use a price made stale by the first), every applied
// collapse is one of that pass's priced candidates, and within a pass they come cheapest first.
TEST(CollapseEngine, PassesNeverApplyOverlappingEdgesInOnePass) {
  core::Mesh sphere = test::icosphere(3, 1.0f, test::lumps);  // 1280 triangles
  class PassModel : public RecordingModel {
   public:
    void onCollapse(const mesh::EngineState& state, const mesh::AppliedCollapse& applied) override {
      RecordingModel::onCollapse(state, applied);
      pass_of.push_back(batches.size() - 1);
    }
    std::vector<size_t> pass_of;
  } model;
  mesh::EngineOptions options{.target_triangles = 100,
                              .ordering = mesh::CollapseOrdering::kPasses,
                              .greedy_tail_triangles = 0};
  auto result = mesh::runCollapseEngine(mesh::prepareMesh(sphere), model, options);
  EXPECT_EQ(result.mesh.triangleCount(), 100u);
  ASSERT_EQ(model.pass_of.size(), model.applied_collapses.size());
  EXPECT_GT(model.batches.size(), 2u);  // several passes were needed
  std::set<uint32_t> touched;
  std::set<std::pair<uint32_t, uint32_t>> priced;
  size_t pass = SIZE_MAX;
  double last_cost = 0;
  for (size_t k = 0; k < model.applied_collapses.size(); ++k) {
    const auto& c = model.applied_collapses[k].candidate;
    if (model.pass_of[k] != pass) {
      pass = model.pass_of[k];
      touched.clear();
      priced.clear();
      for (const auto& p : model.batches[pass]) priced.insert({p.from, p.to});
      last_cost = 0;
    }
    EXPECT_TRUE(touched.insert(c.from).second) << "collapse " << k << " reuses " << c.from;
    EXPECT_TRUE(touched.insert(c.to).second) << "collapse " << k << " reuses " << c.to;
    EXPECT_TRUE(priced.count({c.from, c.to})) << "collapse " << k << " was not priced this pass";
    EXPECT_GE(c.cost, last_cost);
    last_cost = c.cost;
  }
}

// QuadricModel prices a batch of 4096 candidates or more in two halves on two cores (runBoth):
// its prices must be those of one loop, bit for bit. A second model follows the same collapses
// and prices a copy of every batch in slices of 64 (one core); the two are compared.
TEST(CollapseEngine, QuadricPricesOnTwoCoresAreThoseOfOne) {
  if (std::thread::hardware_concurrency() < 2)
    GTEST_SKIP() << "one core: runBoth prices both halves on this thread, nothing to compare";
  core::Mesh grid = test::seamGrid(
      64, [](float x, float y) { return 0.1f * std::sin(7.0f * x) * std::cos(5.0f * y); });
  class CheckedModel : public mesh::CostModel {
   public:
    void begin(const mesh::EngineState& state) override {
      fast.begin(state);
      reference.begin(state);
    }
    void evaluate(const mesh::EngineState& state, std::span<mesh::CandidateCollapse> batch) override {
      std::vector<mesh::CandidateCollapse> copy(batch.begin(), batch.end());
      fast.evaluate(state, batch);
      for (size_t i = 0; i < copy.size(); i += 64)
        reference.evaluate(state, std::span(copy).subspan(i, std::min<size_t>(64, copy.size() - i)));
      large_batches += batch.size() >= 4096;
      for (size_t i = 0; i < copy.size(); ++i) {
        const mesh::CandidateCollapse &a = batch[i], &b = copy[i];
        compared += 1;
        mismatches += std::memcmp(&a.cost, &b.cost, sizeof a.cost) != 0 ||
                      std::memcmp(&a.error, &b.error, sizeof a.error) != 0 ||
                      std::memcmp(&a.position, &b.position, sizeof a.position) != 0;
      }
    }
    void placeAttributes(const mesh::EngineState& state, const mesh::CandidateCollapse& chosen,
                         std::span<float> values) override {
      fast.placeAttributes(state, chosen, values);
    }
    void refinePlacement(const mesh::EngineState& state, mesh::CandidateCollapse& chosen) override {
      fast.refinePlacement(state, chosen);
    }
    void setPassPricing(bool passes) override {
      fast.setPassPricing(passes);
      reference.setPassPricing(passes);
    }
    void onCollapse(const mesh::EngineState& state, const mesh::AppliedCollapse& applied) override {
      fast.onCollapse(state, applied);
      reference.onCollapse(state, applied);
    }
    mesh::QuadricModel fast{{}}, reference{{}};
    size_t large_batches = 0, compared = 0, mismatches = 0;
  } model;
  auto result = mesh::runCollapseEngine(
      mesh::prepareMesh(grid), model,
      {.target_triangles = 200, .ordering = mesh::CollapseOrdering::kPasses});
  EXPECT_LE(result.mesh.triangleCount(), 200u);
  EXPECT_GT(model.large_batches, 0u);
  EXPECT_GT(model.compared, 20000u);
  EXPECT_EQ(model.mismatches, 0u);
}

// Both orderings run the same rules and reach the target on a seamed, curved grid.
TEST(CollapseEngine, PassesAndGreedyBothReachTheTarget) {
  core::Mesh grid = test::seamGrid(12, [](float x, float y) { return 0.1f * x * y; });
  for (auto ordering : {mesh::CollapseOrdering::kGreedy, mesh::CollapseOrdering::kPasses}) {
    RecordingModel model;
    auto result = mesh::runCollapseEngine(
        mesh::prepareMesh(grid), model,
        {.target_triangles = 60, .ordering = ordering, .greedy_tail_triangles = 0});
    EXPECT_LE(result.mesh.triangleCount(), 60u);
    EXPECT_GT(result.stats.collapses, 100u);
  }
}

// prepareMesh drops a triangle that repeats an earlier one's positions in the same orientation
// (rotated, or through another vertex at the same position) and keeps the first; the reversed
// triangle is a different face and stays. Order is kept.
// The passes hand the last collapses to the greedy queue only at the coarse end: 2000 triangles
// or 1/16 of the input, when the target is at most 4 times that.
TEST(GreedyTail, OnlyAtTheCoarseEnd) {
  mesh::EngineOptions options;
  options.target_triangles = 7541;  // bunny at 10%
  EXPECT_EQ(mesh::greedyTailTriangles(options, 75408), 2000u);
  options.target_triangles = 8000;
  EXPECT_EQ(mesh::greedyTailTriangles(options, 75408), 2000u);
  options.target_triangles = 8001;
  EXPECT_EQ(mesh::greedyTailTriangles(options, 75408), 0u);
  options.target_triangles = 37704;  // bunny at 50%
  EXPECT_EQ(mesh::greedyTailTriangles(options, 75408), 0u);
  options.target_triangles = 1124;  // a 4510-triangle mesh: 4510 / 16 = 281, 4 * 281 = 1124
  EXPECT_EQ(mesh::greedyTailTriangles(options, 4510), 281u);
  options.target_triangles = 1125;
  EXPECT_EQ(mesh::greedyTailTriangles(options, 4510), 0u);
  options.target_triangles = 0;  // an error target only: the passes run to it
  EXPECT_EQ(mesh::greedyTailTriangles(options, 4510), 281u);
}

TEST(PassEnds, FinishingStallingAndNearingTheTail) {
  // Finishing: at most a seventh of the goal left undone by the cheap part.
  EXPECT_TRUE(mesh::passFinishes(100, 700));
  EXPECT_FALSE(mesh::passFinishes(101, 700));
  EXPECT_FALSE(mesh::passFinishes(0, 700));  // nothing left: the pass is done
  // Stalling: a quarter of the goal or less applied, within the greedy tail's capacity.
  EXPECT_TRUE(mesh::passStalls(25, 100, 500, 2000));
  EXPECT_FALSE(mesh::passStalls(26, 100, 500, 2000));
  EXPECT_TRUE(mesh::passStalls(0, 100, 2000, 2000));
  EXPECT_FALSE(mesh::passStalls(0, 100, 2001, 2000));  // too much left for the queue
  EXPECT_FALSE(mesh::passStalls(0, 100, 0, 2000));     // at the pass target already
  // The capacity: greedy_tail_triangles, at most 1/16 of the input.
  mesh::EngineOptions options;  // greedy_tail_triangles = 2000
  EXPECT_EQ(mesh::greedyTailCapacity(options, 75408), 2000u);
  EXPECT_EQ(mesh::greedyTailCapacity(options, 7598), 474u);
  // A thin cheap part: fewer edges than 5/4 of the goal.
  EXPECT_TRUE(mesh::passCheapPartThin(124, 100));
  EXPECT_FALSE(mesh::passCheapPartThin(125, 100));
  EXPECT_FALSE(mesh::passCheapPartThin(0, 0));
  // Nearing the tail: at most a quarter of the tail left above the pass target.
  EXPECT_TRUE(mesh::passNearsTail(500, 2000));
  EXPECT_FALSE(mesh::passNearsTail(501, 2000));
  EXPECT_FALSE(mesh::passNearsTail(0, 2000));  // at the pass target already
  EXPECT_FALSE(mesh::passNearsTail(1, 0));     // no tail: the passes go on
}

TEST(PrepareMesh, DropsDuplicateTrianglesKeepsTheFirstAndTheReversed) {
  core::Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 0}, {1, 1, 0}};
  m.indices = {0, 1, 2,   // A
               1, 2, 0,   // A rotated: dropped
               0, 2, 1,   // A reversed: kept
               3, 1, 2,   // A through vertex 3 (at vertex 0's position): dropped
               1, 4, 2,   // B
               2, 1, 4,   // B rotated: dropped
               0, 1, 2};  // A again: dropped
  m.submeshes = {{0, uint32_t(m.indices.size()), 0}};
  const core::Mesh out = mesh::prepareMesh(m);
  EXPECT_EQ(out.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 1, 1, 3, 2}));
  ASSERT_EQ(out.positions.size(), 4u);  // vertex 3 welded into 0; 4 renumbered 3
  EXPECT_EQ(out.positions[3].x, 1.0f);
  EXPECT_EQ(out.positions[3].y, 1.0f);
}

// SecondCore (second_core.hpp): every part of every job runs exactly once, job after job (the
// claim is reused with a new generation each time), whoever runs it; parts may run on the helper.
TEST(SecondCore, EveryPartOfEveryJobRunsOnce) {
  mesh::SecondCore cores;
  std::vector<std::atomic<uint32_t>> runs(257);
  std::atomic<uint32_t> on_helper{0};
  const std::thread::id here = std::this_thread::get_id();
  for (uint32_t job = 0; job < 300; ++job) {
    const uint32_t parts = 1 + job % 257;
    for (uint32_t i = 0; i < parts; ++i) runs[i] = 0;
    cores.forEach(parts, [&](uint32_t part) {
      // A few microseconds of work a part, so that the helper joins in.
      const auto until = std::chrono::steady_clock::now() + std::chrono::microseconds(2);
      while (std::chrono::steady_clock::now() < until) {
      }
      runs[part].fetch_add(1);
      if (std::this_thread::get_id() != here) on_helper.fetch_add(1);
    });
    for (uint32_t i = 0; i < parts; ++i)
      ASSERT_EQ(runs[i].load(), 1u) << "job " << job << " part " << i;
  }
  if (!cores.available()) {
    EXPECT_EQ(on_helper.load(), 0u);
    GTEST_SKIP() << "no second core (one core, or the helper is held): every part ran here";
  }
  std::printf("parts run on the helper: %u\n", on_helper.load());
  EXPECT_GT(on_helper.load(), 0u);
}

// One holder at a time: a second SecondCore (another call, or one nested inside a part) works
// alone, and gets the helper once the first lets it go.
TEST(SecondCore, OneHolderAtATime) {
  if (mesh::second_core_detail::usableCpus() < 2)
    GTEST_SKIP() << "one usable CPU: there is no helper to hold";
  std::optional<mesh::SecondCore> first;
  first.emplace();
  ASSERT_TRUE(first->available());
  {
    mesh::SecondCore second;
    EXPECT_FALSE(second.available());
    std::vector<int> ran(10, 0);
    second.forEach(10, [&](uint32_t part) { ++ran[part]; });  // here, in order
    EXPECT_EQ(ran, std::vector<int>(10, 1));
  }
  std::atomic<int> nested_available{0}, nested_parts{0};
  first->forEach(4, [&](uint32_t) {
    mesh::SecondCore nested;
    nested_available += nested.available();
    nested.forEach(3, [&](uint32_t) { ++nested_parts; });
  });
  EXPECT_EQ(nested_available.load(), 0);
  EXPECT_EQ(nested_parts.load(), 12);
  // The holder's own forEach inside one of its parts runs there, whichever thread that is.
  std::atomic<int> inner_parts{0};
  first->forEach(4, [&](uint32_t) { first->forEach(5, [&](uint32_t) { ++inner_parts; }); });
  EXPECT_EQ(inner_parts.load(), 20);
  first.reset();
  mesh::SecondCore third;
  EXPECT_TRUE(third.available());
}

// The position-only fast path applies a pass's collapses in two halves of a large mesh, on two
// cores when it has them: the result must not depend on whether it had them. Here the helper is
// held by this test, so the simplifier runs both halves on one core; the outputs must be equal,
// bit for bit, to those of a run with the helper.
TEST(SecondCore, SimplifyingIsTheSameOnOneCoreAsOnTwo) {
  const core::Mesh input = test::icosphere(6, 1.0f, test::lumps);  // 40,962 positions
  for (size_t target : {input.triangleCount() / 2, input.triangleCount() / 10, size_t(400)}) {
    const mesh::SimplifyOptions options{.target_triangles = target};
    const mesh::SimplifyResult two = mesh::simplifyQuadric(input, options);
    mesh::SimplifyResult one;
    {
      mesh::SecondCore held;  // the simplifier finds the helper taken
      one = mesh::simplifyQuadric(input, options);
    }
    EXPECT_EQ(two.mesh.indices, one.mesh.indices) << target;
    ASSERT_EQ(two.mesh.positions.size(), one.mesh.positions.size()) << target;
    EXPECT_EQ(0, std::memcmp(two.mesh.positions.data(), one.mesh.positions.data(),
                             one.mesh.positions.size() * sizeof(core::Vec3)))
        << target;
    ASSERT_EQ(two.record.steps.size(), one.record.steps.size()) << target;
    for (size_t i = 0; i < one.record.steps.size(); ++i) {
      const mesh::CollapseStep &a = two.record.steps[i], &b = one.record.steps[i];
      ASSERT_TRUE(a.removed == b.removed && a.kept == b.kept && a.kept_value == b.kept_value &&
                  a.triangles_after == b.triangles_after && a.error == b.error &&
                  a.cumulative_error == b.cumulative_error && a.continues == b.continues)
          << target << ": step " << i;
    }
    ASSERT_EQ(two.record.values.positions.size(), one.record.values.positions.size()) << target;
    EXPECT_EQ(0, std::memcmp(two.record.values.positions.data(), one.record.values.positions.data(),
                             one.record.values.positions.size() * sizeof(core::Vec3)))
        << target;
    EXPECT_EQ(two.error, one.error) << target;
    EXPECT_EQ(two.stats.collapses, one.stats.collapses) << target;
    EXPECT_EQ(two.stats.rejected_flip, one.stats.rejected_flip) << target;
    EXPECT_EQ(two.mesh.triangleCount(), target) << target;
  }
}

// The helper runs a job's parts under its caller's floating-point rounding (it was started under
// another): rounding upwards, a run with the helper equals one without it.
TEST(SecondCore, TheHelperRoundsAsItsCallerDoes) {
  const core::Mesh input = test::icosphere(6, 1.0f, test::lumps);
  const mesh::SimplifyOptions options{.target_triangles = 8192};
  (void)mesh::simplifyQuadric(input, options);  // the helper exists, under the default rounding
  const int rounding = std::fegetround();
  ASSERT_EQ(std::fesetround(FE_UPWARD), 0);
  const mesh::SimplifyResult two = mesh::simplifyQuadric(input, options);
  mesh::SimplifyResult one;
  {
    mesh::SecondCore held;
    one = mesh::simplifyQuadric(input, options);
  }
  std::fesetround(rounding);
  EXPECT_EQ(two.mesh.indices, one.mesh.indices);
  ASSERT_EQ(two.mesh.positions.size(), one.mesh.positions.size());
  EXPECT_EQ(0, std::memcmp(two.mesh.positions.data(), one.mesh.positions.data(),
                           one.mesh.positions.size() * sizeof(core::Vec3)));
}

// runBoth (run_both.hpp) on the helper, one call after another (the helper sleeps after each
// part it runs, and must be woken for the next), on a thread of its own when the helper is held,
// and nested: both pieces run once each, and an exception from either comes back to the caller.
TEST(RunBoth, BothRunOnceAndTheirExceptionsComeBack) {
  const std::thread::id here = std::this_thread::get_id();
  int on_other_thread = 0;
  for (int call = 0; call < 200; ++call) {
    int first = 0, second = 0;
    std::thread::id second_on;
    mesh::runBoth(
        [&] {
          // Long enough for a sleeping helper to wake and take the second piece.
          const auto until = std::chrono::steady_clock::now() + std::chrono::microseconds(300);
          while (std::chrono::steady_clock::now() < until) {
          }
          ++first;
        },
        [&] {
          ++second;
          second_on = std::this_thread::get_id();
        });
    ASSERT_EQ(first, 1) << call;
    ASSERT_EQ(second, 1) << call;
    on_other_thread += second_on != here;
  }
  std::printf("second pieces run on another thread: %d of 200\n", on_other_thread);
  auto throws_in = [](int which) {
    std::atomic<int> ran{0};  // the pieces may run at once
    try {
      mesh::runBoth(
          [&] {
            ++ran;
            if (which == 0) throw std::runtime_error("first");
          },
          [&] {
            ++ran;
            if (which == 1) throw std::runtime_error("second");
          });
    } catch (const std::runtime_error& e) {
      // Nothing runs after the exception came back (on one core, `second` is not started once
      // `first` threw).
      EXPECT_GE(ran.load(), which == 0 ? 1 : 2) << e.what();
      return std::string(e.what());
    }
    return std::string("none");
  };
  EXPECT_EQ(throws_in(0), "first");
  EXPECT_EQ(throws_in(1), "second");
  EXPECT_EQ(throws_in(2), "none");
  {
    mesh::SecondCore held;  // the helper is taken: a thread of its own (or, on one core, here)
    EXPECT_EQ(throws_in(1), "second");
    std::atomic<int> inner{0};
    mesh::runBoth([&] { mesh::runBoth([&] { ++inner; }, [&] { ++inner; }); },
                  [&] { mesh::runBoth([&] { ++inner; }, [&] { ++inner; }); });
    EXPECT_EQ(inner.load(), 4);
  }
  std::atomic<int> nested{0};
  mesh::runBoth([&] { mesh::runBoth([&] { ++nested; }, [&] { ++nested; }); },
                [&] { mesh::runBoth([&] { ++nested; }, [&] { ++nested; }); });
  EXPECT_EQ(nested.load(), 4);
  if (mesh::second_core_detail::usableCpus() >= 2) {
    EXPECT_GT(on_other_thread, 0);
  }
}

}  // namespace
}  // namespace duolod
