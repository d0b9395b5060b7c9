// SearchPairs (Algorithm 2) driven by real renders: WaterBottle with quadric-simplified meshes and
// two shaders (the PBR original and the constant-colour shader as its simplest variant), against
// the 2D brute force over the same cached evaluations.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "duolod/io.hpp"
#include "duolod/lod.hpp"
#include "duolod/mesh.hpp"
#include "test_support.hpp"

namespace duolod {
namespace {

TEST(LodRenderedSearch, WaterBottleWalkAgreesWithBruteForceInFewerRenders) {
  DUOLOD_REQUIRE_ASSET(path, "gltf/WaterBottle/WaterBottle.gltf");
  auto created = render::Renderer::create();
  ASSERT_TRUE(created) << "no OpenGL 4.5 context: " << created.error().message;
  render::Renderer& renderer = **created;
  auto asset = io::loadAsset(path);
  ASSERT_TRUE(asset) << asset.error().message;

  // M_0 .. M_5: the original and quadric simplifications to 50% .. 3% of its triangles.
  std::vector<core::Mesh> meshes = {asset->mesh};
  for (double ratio : {0.5, 0.25, 0.12, 0.06, 0.03})
    meshes.push_back(
        mesh::simplifyQuadric(
            asset->mesh,
            {.target_triangles = size_t(ratio * asset->mesh.triangleCount()), .record = false})
            .mesh);
  std::vector<render::Renderer::AssetId> mesh_ids;
  auto original = renderer.uploadAsset(*asset);
  ASSERT_TRUE(original) << original.error().message;
  mesh_ids.push_back(*original);
  for (size_t k = 1; k < meshes.size(); ++k) {
    auto id = renderer.uploadMesh(*original, meshes[k]);
    ASSERT_TRUE(id) << id.error().message;
    mesh_ids.push_back(*id);
  }
  std::vector<render::Renderer::ProgramId> shader_ids;
  for (const char* name : {"shaders/pbr", "shaders/constant"}) {
    auto source = render::loadShaderPair(test::sourcePath(name));
    ASSERT_TRUE(source) << source.error().message;
    auto program = renderer.compileProgram(*source);
    ASSERT_TRUE(program) << program.error().message;
    shader_ids.push_back(*program);
  }

  // A level where the bottle covers ~48 px; the cost is predicted (triangles, and the constant
  // shader at a tenth of the PBR one) so the test is deterministic.
  core::Sphere sphere = core::computeBoundingSphere(asset->mesh);
  lod::LevelOptions level_options;
  level_options.bound = {
      .d_near = 2 * sphere.radius, .d_far = 60 * sphere.radius, .q = 0.5f, .e_max = 0.1f};
  auto levels = lod::distanceLevels(sphere, level_options);
  ASSERT_TRUE(levels) << levels.error().message;
  const lod::DistanceLevel& level = (*levels)[5];
  lod::RenderedPairOptions pair_options;
  pair_options.predicted_cost = [&](int mesh, int shader) {
    return double(meshes[mesh].triangleCount()) * (shader == 0 ? 1.0 : 0.1);
  };
  auto evaluator = lod::RenderedPairEvaluator::create(renderer, mesh_ids, shader_ids, sphere,
                                                      level.distance, pair_options);
  ASSERT_TRUE(evaluator) << evaluator.error().message;
  EXPECT_EQ(evaluator->footprintPixels(), level.footprint_px);
  ASSERT_GT(evaluator->coveragePixels(), 0.0);
  EXPECT_LT(evaluator->coveragePixels(), level.footprint_px * level.footprint_px);

  // SortByError on M_0.
  std::vector<double> error_on_original;
  for (int s = 0; s < 2; ++s) {
    auto pair = evaluator->evaluate(0, s);
    ASSERT_TRUE(pair) << pair.error().message;
    error_on_original.push_back(pair->error);
  }
  EXPECT_LT(error_on_original[0], error_on_original[1]);  // the original shader is the accurate one
  std::vector<int> order = lod::sortByError(error_on_original);

  const double bound = lod::errorBound(level, evaluator->coveragePixels());
  lod::PairSearchOptions options{.error_bound = bound, .time_tolerance = 0.05};
  auto walk = lod::searchPairs(int(meshes.size()), order, evaluator->evaluator(), options);
  ASSERT_TRUE(walk) << walk.error().message;
  const int rendered_by_walk = evaluator->renderedPairs();
  auto brute =
      lod::searchPairsBruteForce(int(meshes.size()), order, evaluator->evaluator(), options);
  ASSERT_TRUE(brute) << brute.error().message;
  EXPECT_LE(walk->evaluations, int(meshes.size()) + 2);
  EXPECT_EQ(brute->evaluations, int(meshes.size()) * 2);
  EXPECT_EQ(evaluator->renderedPairs(), int(meshes.size()) * 2);  // the cache served the rest
  std::printf(
      "level d = %.3f, %d px, s_d = %.1f px, bound %.3f: walk %d evaluations (%d renders), "
      "brute force %d\n",
      level.distance, level.footprint_px, evaluator->coveragePixels(), bound, walk->evaluations,
      rendered_by_walk, brute->evaluations);
  for (const lod::EvaluatedPair& pair : brute->visited)
    std::printf("  M%d (%zu tris) S%d: error %.3f %s, cost %.0f\n", pair.mesh,
                meshes[pair.mesh].triangleCount(), pair.shader, pair.error,
                pair.within_bound ? "within" : "over  ", pair.cost);
  // Image error grows as the mesh is simplified with either shader (the monotonicity Algorithm 2
  // relies on), so the walk finds the brute force's optimum.
  ASSERT_FALSE(brute->optimal.empty()) << "nothing within the bound at this level";
  ASSERT_FALSE(walk->optimal.empty());
  EXPECT_EQ(walk->optimal[0].mesh, brute->optimal[0].mesh);
  EXPECT_EQ(walk->optimal[0].shader, brute->optimal[0].shader);

  // A tighter bound, halfway (geometrically) between the errors of M_3 and M_4 with the original
  // shader, puts the boundary mid-way down the mesh axis: the cheapest pair is then (M_3, S_0).
  auto error_of = [&](int mesh) { return evaluator->evaluate(mesh, order[0])->error; };
  ASSERT_GT(error_of(4), error_of(3));
  options.error_bound = std::sqrt(error_of(3) * error_of(4));
  options.time_tolerance = 0;
  auto tight_walk = lod::searchPairs(int(meshes.size()), order, evaluator->evaluator(), options);
  auto tight_brute =
      lod::searchPairsBruteForce(int(meshes.size()), order, evaluator->evaluator(), options);
  ASSERT_TRUE(tight_walk && tight_brute);
  ASSERT_EQ(tight_walk->optimal.size(), 1u);
  EXPECT_EQ(tight_walk->optimal[0].mesh, 3);
  EXPECT_EQ(tight_walk->optimal[0].shader, order[0]);
  EXPECT_EQ(tight_brute->optimal[0].mesh, 3);
  EXPECT_LE(tight_walk->evaluations, int(meshes.size()) + 2);

  // Measured cost: wall clock in milliseconds (only its presence is checked: tests never assert
  // on time), errors identical to the predicted-cost evaluator's, and a needed cost is enforced.
  lod::RenderedPairOptions timed_options;
  timed_options.timing_repeats = 3;
  auto timed = lod::RenderedPairEvaluator::create(renderer, mesh_ids, shader_ids, sphere,
                                                  level.distance, timed_options);
  ASSERT_TRUE(timed) << timed.error().message;
  auto timed_pair = timed->evaluate(5, 0);
  ASSERT_TRUE(timed_pair) << timed_pair.error().message;
  EXPECT_GT(timed_pair->cost, 0.0);
  EXPECT_DOUBLE_EQ(timed_pair->error, evaluator->evaluate(5, 0)->error);
  EXPECT_FALSE(timed->evaluate(6, 0).ok());  // no such mesh
  EXPECT_FALSE(lod::RenderedPairEvaluator::create(renderer, mesh_ids, shader_ids, sphere,
                                                  level.distance, lod::RenderedPairOptions{})
                   .ok());
}

}  // namespace
}  // namespace duolod
