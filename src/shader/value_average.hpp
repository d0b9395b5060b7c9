// The average of a fragment value over the training domain (He et al. 2015, "moving to
// parameter": n → average(n)), by an instrumented render: a copy of the fragment stage writes the
// value, instead of the colour, at every pixel where it is computed; the mean over those pixels
// of all view × light samples is the average. Plugs into RuleContext::average_value.
//
// The renderer's targets are 8-bit (RGBA8, also behind renderReference's float tiles), so values
// are not written as colours: one component per render is squashed into (0, 1) by
// y = (1 + x / (1 + |x|)) / 2 and spread over R, G, B as 24 bits (R the top byte), alpha 1 marking
// the pixel; background and pixels where the value is not computed keep alpha 0. Decoding gives x
// back to ~1e-6 relative for |x| up to ~100, so the mean over many pixels is exact for our needs.
#pragma once

#include <cstdint>
#include <functional>
#include <unordered_map>
#include <vector>

#include "duolod/core.hpp"
#include "duolod/render.hpp"
#include "shader/ir.hpp"
#include "shader/rules.hpp"

namespace duolod::shader {

// The fragment module of `program` rewritten to output component `component` of `value` (encoded
// as above) instead of its colour; the program's parameters are baked in as constants so no CPU
// state is needed. Fails when `value` is not a 32-bit float scalar/vector of the fragment entry
// point outside loops, or the module has no vec4 colour output at location 0.
core::Result<ir::Module> instrumentFragmentValue(const ShaderProgram& program, ir::Id value,
                                                 uint32_t component);

// Replaces every load of a loose uniform that `parameters` set (by location) by the constant value,
// so the module renders the same without the CPU setting anything (the instrumented copies, and
// self-contained variants).
core::Status bakeParameters(ir::Module& module, const std::vector<ParameterValue>& parameters);

// Decodes one pixel written by the instrumented module (bytes R, G, B).
float decodeAveragedPixel(uint8_t red, uint8_t green, uint8_t blue);

struct AverageOptions {
  int resolution = 64;  // tile side of each sample's render
};

// Renders instrumented programs of an uploaded asset over fixed samples. Results are cached by the
// instrumented program's words, so asking again for the same value is free.
class ValueAverager {
 public:
  ValueAverager(render::Renderer& renderer, render::Renderer::AssetId asset,
                std::vector<render::Sample> samples, AverageOptions options = {});

  // The mean of each component of fragment value `value` over covered pixels. Stage::kFragment
  // only.
  core::Result<std::vector<float>> average(const ShaderProgram& program, Stage stage, ir::Id value);
  // A callable for RuleContext::average_value that refers to this averager.
  std::function<core::Result<std::vector<float>>(const ShaderProgram&, Stage, ir::Id)> function();

  struct Counters {
    int renders = 0;     // instrumented programs compiled and rendered
    int cache_hits = 0;  // components answered from the cache
    int64_t pixels = 0;  // covered pixels averaged, all renders
  };
  const Counters& counters() const { return counters_; }

 private:
  core::Result<float> averageComponent(const ShaderProgram& program, ir::Id value,
                                       uint32_t component);

  render::Renderer& renderer_;
  render::Renderer::AssetId asset_;
  std::vector<render::Sample> samples_;
  AverageOptions options_;
  std::unordered_map<uint64_t, float> cache_;
  Counters counters_;
};

}  // namespace duolod::shader
