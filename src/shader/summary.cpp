// Short summaries of rule applications (shader/summary.hpp). The rules describe each site in
// words with source names (RuleSite::description, formats fixed by the rule files); this groups
// them so a level with a dozen sites still reads in one line.
#include "shader/summary.hpp"

#include <map>
#include <vector>

namespace duolod::shader {
namespace {

// The text between `prefix` and `suffix` of a description; the whole description when it does
// not have that shape (a rule's wording changed: better verbose than wrong).
std::string between(const std::string& text, const std::string& prefix, const std::string& suffix) {
  size_t start = text.find(prefix);
  if (start == std::string::npos) return text;
  start += prefix.size();
  size_t end = suffix.empty() ? text.size() : text.find(suffix, start);
  if (end == std::string::npos) return text;
  return text.substr(start, end - start);
}

// "fragment: fbm loop: 4 → 2 iterations" → "fbm loop: 4 → 2 iterations".
std::string withoutStage(const std::string& text) {
  for (const char* stage : {"fragment: ", "vertex: "})
    if (text.rfind(stage, 0) == 0) return text.substr(std::string(stage).size());
  return text;
}

// Named values listed, unnamed ones (SPIR-V ids, "%123") counted.
std::string valueList(const std::vector<std::string>& values) {
  std::string text;
  int unnamed = 0;
  for (const std::string& value : values) {
    if (value.empty() || value[0] == '%') {
      ++unnamed;
      continue;
    }
    if (!text.empty()) text += ", ";
    text += value;
  }
  if (unnamed > 0) {
    std::string count = std::to_string(unnamed) + (unnamed == 1 ? " unnamed value" : " unnamed values");
    text = text.empty() ? count : text + " and " + count;
  }
  return text;
}

}  // namespace

std::string summarizeSites(std::span<const RuleSite> sites) {
  if (sites.empty()) return "original";
  std::vector<std::string> loops, textures, per_vertex, parameters;
  std::map<std::string, int> removed_in;  // function → operations removed there
  int removed = 0;
  for (const RuleSite& site : sites) {
    switch (site.kind) {
      case RuleKind::kLoopTruncation: {
        // "fbm loop: 4 → 2 iterations" then "fbm loop: 2 → 1 iterations" read as one truncation,
        // 4 → 1: the later site replaces the earlier one's end.
        std::string text = withoutStage(site.description);
        const size_t arrow = text.find(" → ");
        const size_t colon = text.rfind(": ", arrow);
        bool merged = false;
        if (arrow != std::string::npos && colon != std::string::npos) {
          const std::string label = text.substr(0, colon);
          for (std::string& loop : loops)
            if (loop.rfind(label + ": ", 0) == 0 && loop.find(" → ") != std::string::npos) {
              loop = loop.substr(0, loop.find(" → ")) + text.substr(arrow);
              merged = true;
              break;
            }
        }
        if (!merged) loops.push_back(std::move(text));
        break;
      }
      case RuleKind::kTextureAverage:
        textures.push_back(between(withoutStage(site.description), "", " sample") +
                           " → average colour");
        break;
      case RuleKind::kTextureMip:
        textures.push_back(between(withoutStage(site.description), "", " sample") + " " +
                           between(site.description, "→ ", " mip") + " mip level(s) coarser");
        break;
      case RuleKind::kPerVertex:
        per_vertex.push_back(between(withoutStage(site.description), "", " computed in"));
        break;
      case RuleKind::kMoveToParameter:
        parameters.push_back(between(withoutStage(site.description), "", " → its average"));
        break;
      case RuleKind::kOperationRemoval: {
        // "<stage> <function>: op(a, b) → a"
        const std::string& text = site.description;
        size_t space = text.find(' '), colon = text.find(':');
        std::string function = space != std::string::npos && colon != std::string::npos &&
                                       space < colon
                                   ? text.substr(space + 1, colon - space - 1)
                                   : std::string("?");
        ++removed_in[function];
        ++removed;
        break;
      }
    }
  }
  std::vector<std::string> parts;
  for (std::string& loop : loops) parts.push_back(std::move(loop));
  for (std::string& texture : textures) parts.push_back(std::move(texture));
  if (!per_vertex.empty()) parts.push_back("per vertex: " + valueList(per_vertex));
  if (!parameters.empty()) parts.push_back("constant (domain average): " + valueList(parameters));
  if (removed > 0) {
    std::string where;
    for (const auto& [function, count] : removed_in)
      where += (where.empty() ? "" : ", ") + function + (count > 1 ? " ×" + std::to_string(count) : "");
    parts.push_back(std::to_string(removed) + (removed == 1 ? " operation" : " operations") +
                    " removed (" + where + ")");
  }
  std::string summary;
  for (const std::string& part : parts) summary += (summary.empty() ? "" : "; ") + part;
  return summary;
}

}  // namespace duolod::shader
