// TEMPORARY (branch rules2): the declarations rules_internal.hpp will hold once it is in main.
#pragma once

#include <vector>

#include "shader/rules.hpp"

namespace duolod::shader {

std::vector<RuleSite> findMoveToParameterSites(const ShaderProgram& program,
                                               const RuleContext& context);
core::Result<ShaderProgram> applyMoveToParameter(const ShaderProgram& program, const RuleSite& site,
                                                 const RuleContext& context);

std::vector<RuleSite> findPerVertexSites(const ShaderProgram& program, const RuleContext& context);
core::Result<ShaderProgram> applyPerVertex(const ShaderProgram& program, const RuleSite& site,
                                           const RuleContext& context);

}  // namespace duolod::shader
