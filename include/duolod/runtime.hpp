// duolod runtime: what an engine links to use a duolod LOD. Header-only, standard library only, no
// dependency on the rest of duolod. It reads the `lod.json` policy that `duolod generate` writes
// and picks a level from the camera distance or from the object's screen coverage, with a
// hysteresis band (no flicker when the camera hovers at a switch distance) and an optional
// cross-fade weight for dithered transitions.
//
// Levels follow Liang et al., "Automatic Mesh and Shader Level of Detail", §3.1: level i is used
// for camera-to-object distances in [d_i, d_{i+1}); level 0 from 0, the last to infinity.
//
// lod.json (format "duolod-lod", version 1) — fields the runtime reads:
//   { "format": "duolod-lod", "version": 1,
//     "levels": [ { "level": 0, "switch_distance": 0, "screen_coverage": 1,
//                   "triangles": 4510, "mesh": "lod.gltf#node0",
//                   "shader": { "summary": "...", "files": { "glsl450_frag": "..." },
//                               "parameters": [ { "name": "n", "location": 40,
//                                                 "value": [0.5, 0.2, 0.1] } ] } }, ... ] }
// switch_distance increases and screen_coverage decreases from level to level. Other fields
// (errors, costs, the asset, display and bound) are for tools and people; they are skipped.
//
// Usage:
//   duolod::runtime::Policy policy;
//   std::string error;
//   if (!duolod::runtime::loadPolicy("lod/lod.json", policy, &error)) { ...report error... }
//   duolod::runtime::LevelSelector selector(policy, {.hysteresis = 0.1, .fade_band = 0.05});
//   auto pick = selector.selectByDistance(distance);   // each frame
//   if (pick.fade_level < 0) draw(pick.level);
//   else drawDithered(pick.level, 1 - pick.fade), drawDithered(pick.fade_level, pick.fade);
#pragma once

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <locale>
#include <map>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace duolod::runtime {

// ---------------------------------------------------------------------------------------------
// A small JSON reader (RFC 8259): enough for lod.json, so the header needs nothing else. Numbers
// are doubles; \u escapes outside ASCII are decoded to UTF-8.

class JsonValue {
 public:
  enum class Kind { kNull, kBool, kNumber, kString, kArray, kObject };

  Kind kind() const { return kind_; }
  bool isNumber() const { return kind_ == Kind::kNumber; }
  bool isString() const { return kind_ == Kind::kString; }
  bool isArray() const { return kind_ == Kind::kArray; }
  bool isObject() const { return kind_ == Kind::kObject; }
  double number(double fallback = 0) const { return isNumber() ? number_ : fallback; }
  const std::string& string() const { return string_; }
  bool boolean() const { return kind_ == Kind::kBool && boolean_; }
  const std::vector<JsonValue>& items() const { return items_; }
  const std::vector<std::pair<std::string, JsonValue>>& members() const { return members_; }
  // The member named `key`, or nullptr (also when this is not an object).
  const JsonValue* find(std::string_view key) const {
    for (const auto& [name, value] : members_)
      if (name == key) return &value;
    return nullptr;
  }

  // Parses `text`; on failure returns false and sets `error` to "offset N: reason".
  static bool parse(std::string_view text, JsonValue& out, std::string* error) {
    out = JsonValue{};  // a value parsed into before is replaced, not added to
    Parser parser{text, 0, {}};
    bool ok = parser.value(out, 0) &&
              (parser.skipSpace(),
               parser.at == text.size() || parser.fail("unexpected text after the JSON value"));
    if (!ok && error) *error = "offset " + std::to_string(parser.at) + ": " + parser.message;
    return ok;
  }

 private:
  struct Parser {
    std::string_view text;
    size_t at;
    std::string message;

    static constexpr int kMaxDepth =
        64;  // deeper input is refused rather than overflowing the stack
    bool fail(const char* reason) {
      message = reason;
      return false;
    }
    void skipSpace() {
      while (at < text.size() &&
             (text[at] == ' ' || text[at] == '\t' || text[at] == '\n' || text[at] == '\r'))
        ++at;
    }
    bool literal(std::string_view word) {
      if (text.substr(at, word.size()) != word) return fail("invalid literal");
      at += word.size();
      return true;
    }
    bool value(JsonValue& out, int depth) {
      if (depth > kMaxDepth) return fail("nesting too deep");
      skipSpace();
      if (at >= text.size()) return fail("unexpected end of input");
      char c = text[at];
      if (c == '{') return object(out, depth);
      if (c == '[') return array(out, depth);
      if (c == '"') {
        out.kind_ = Kind::kString;
        return string(out.string_);
      }
      if (c == 't' || c == 'f') {
        out.kind_ = Kind::kBool;
        out.boolean_ = c == 't';
        return literal(c == 't' ? "true" : "false");
      }
      if (c == 'n') {
        out.kind_ = Kind::kNull;
        return literal("null");
      }
      return number(out);
    }
    bool number(JsonValue& out) {
      size_t start = at;
      if (at < text.size() && text[at] == '-') ++at;
      auto digits = [&] {
        size_t first = at;
        while (at < text.size() && text[at] >= '0' && text[at] <= '9') ++at;
        return at > first;
      };
      if (!digits()) return fail("invalid number");
      if (at < text.size() && text[at] == '.') {
        ++at;
        if (!digits()) return fail("invalid number");
      }
      if (at < text.size() && (text[at] == 'e' || text[at] == 'E')) {
        ++at;
        if (at < text.size() && (text[at] == '+' || text[at] == '-')) ++at;
        if (!digits()) return fail("invalid number");
      }
      // Not strtod: it reads the C locale's decimal point, so in a comma-decimal locale (an engine
      // that called setlocale(LC_ALL, "")) "2.5" read as 2. from_chars where the library has it
      // for double, else a stream in the classic locale (libc++ before LLVM 20 lacks it).
#if defined(__cpp_lib_to_chars) && __cpp_lib_to_chars >= 201611L
      const char* first = text.data() + start;
      const auto [end, status] = std::from_chars(first, text.data() + at, out.number_);
      if (status == std::errc::result_out_of_range) return fail("number out of range");
      if (status != std::errc() || end != text.data() + at) return fail("invalid number");
#else
      std::istringstream stream{std::string(text.substr(start, at - start))};
      stream.imbue(std::locale::classic());
      stream >> out.number_;
      if (!stream || !std::isfinite(out.number_)) return fail("number out of range");
#endif
      out.kind_ = Kind::kNumber;
      return true;
    }
    static void appendUtf8(std::string& out, uint32_t code) {
      if (code < 0x80) {
        out.push_back(static_cast<char>(code));
      } else if (code < 0x800) {
        out.push_back(static_cast<char>(0xC0 | (code >> 6)));
        out.push_back(static_cast<char>(0x80 | (code & 0x3F)));
      } else if (code < 0x10000) {
        out.push_back(static_cast<char>(0xE0 | (code >> 12)));
        out.push_back(static_cast<char>(0x80 | ((code >> 6) & 0x3F)));
        out.push_back(static_cast<char>(0x80 | (code & 0x3F)));
      } else {
        out.push_back(static_cast<char>(0xF0 | (code >> 18)));
        out.push_back(static_cast<char>(0x80 | ((code >> 12) & 0x3F)));
        out.push_back(static_cast<char>(0x80 | ((code >> 6) & 0x3F)));
        out.push_back(static_cast<char>(0x80 | (code & 0x3F)));
      }
    }
    bool hex4(uint32_t& code) {
      if (at + 4 > text.size()) return fail("truncated \\u escape");
      code = 0;
      for (int i = 0; i < 4; ++i) {
        char h = text[at++];
        code <<= 4;
        if (h >= '0' && h <= '9')
          code |= h - '0';
        else if (h >= 'a' && h <= 'f')
          code |= h - 'a' + 10;
        else if (h >= 'A' && h <= 'F')
          code |= h - 'A' + 10;
        else
          return fail("invalid \\u escape");
      }
      return true;
    }
    bool string(std::string& out) {
      ++at;  // opening quote
      out.clear();
      while (at < text.size()) {
        char c = text[at++];
        if (c == '"') return true;
        if (static_cast<unsigned char>(c) < 0x20) return fail("control character in string");
        if (c != '\\') {
          out.push_back(c);
          continue;
        }
        if (at >= text.size()) break;
        char e = text[at++];
        switch (e) {
          case '"':
          case '\\':
          case '/':
            out.push_back(e);
            break;
          case 'b':
            out.push_back('\b');
            break;
          case 'f':
            out.push_back('\f');
            break;
          case 'n':
            out.push_back('\n');
            break;
          case 'r':
            out.push_back('\r');
            break;
          case 't':
            out.push_back('\t');
            break;
          case 'u': {
            uint32_t code = 0;
            if (!hex4(code)) return false;
            if (code >= 0xD800 && code < 0xDC00 && text.substr(at, 2) == "\\u") {
              at += 2;
              uint32_t low = 0;
              if (!hex4(low)) return false;
              if (low < 0xDC00 || low > 0xDFFF) return fail("invalid surrogate pair");
              code = 0x10000 + ((code - 0xD800) << 10) + (low - 0xDC00);
            }
            appendUtf8(out, code);
            break;
          }
          default:
            return fail("invalid escape in string");
        }
      }
      return fail("unterminated string");
    }
    bool array(JsonValue& out, int depth) {
      ++at;
      out.kind_ = Kind::kArray;
      skipSpace();
      if (at < text.size() && text[at] == ']') return ++at, true;
      while (true) {
        out.items_.emplace_back();
        if (!value(out.items_.back(), depth + 1)) return false;
        skipSpace();
        if (at < text.size() && text[at] == ',') {
          ++at;
          continue;
        }
        if (at < text.size() && text[at] == ']') return ++at, true;
        return fail("expected ',' or ']' in array");
      }
    }
    bool object(JsonValue& out, int depth) {
      ++at;
      out.kind_ = Kind::kObject;
      skipSpace();
      if (at < text.size() && text[at] == '}') return ++at, true;
      while (true) {
        skipSpace();
        if (at >= text.size() || text[at] != '"') return fail("expected a member name");
        std::string name;
        if (!string(name)) return false;
        skipSpace();
        if (at >= text.size() || text[at] != ':') return fail("expected ':' after a member name");
        ++at;
        out.members_.emplace_back(std::move(name), JsonValue{});
        if (!value(out.members_.back().second, depth + 1)) return false;
        skipSpace();
        if (at < text.size() && text[at] == ',') {
          ++at;
          continue;
        }
        if (at < text.size() && text[at] == '}') return ++at, true;
        return fail("expected ',' or '}' in object");
      }
    }
  };

  Kind kind_ = Kind::kNull;
  bool boolean_ = false;
  double number_ = 0;
  std::string string_;
  std::vector<JsonValue> items_;
  std::vector<std::pair<std::string, JsonValue>> members_;
};

// ---------------------------------------------------------------------------------------------
// The policy.

struct Level {
  double switch_distance = 0;  // camera distance from which this level is used
  double screen_coverage = 1;  // screen-area fraction below which this level is used
  uint64_t triangles = 0;
  // The level's mesh: "FILE#nodeK" (what `duolod generate` writes: "lod.gltf#node2"), the glTF
  // file relative to lod.json and the node that holds this level's mesh; or a file alone.
  // meshFile() and meshNode() split it.
  std::string mesh;
  std::string shader_summary;  // in words
  std::map<std::string, std::string>
      shader_files;  // kind ("spirv_frag", "glsl450_frag", ...) → file
  // Uniforms to set before drawing with this level's shader (values averaged over the training
  // domain when the shader was simplified: "moving to parameter").
  struct Parameter {
    std::string name;
    int location = 0;
    std::vector<float> value;  // 1..4 components
  };
  std::vector<Parameter> shader_parameters;

  std::string meshFile() const {
    return meshNode() >= 0 ? mesh.substr(0, mesh.rfind("#node")) : mesh;
  }
  // The node after "#node", or -1 when `mesh` names a file alone.
  int meshNode() const {
    const size_t at = mesh.rfind("#node");
    if (at == std::string::npos) return -1;
    int node = -1;
    const char* first = mesh.data() + at + 5;
    const auto [end, status] = std::from_chars(first, mesh.data() + mesh.size(), node);
    return status == std::errc() && end == mesh.data() + mesh.size() && node >= 0 ? node : -1;
  }
};

struct Policy {
  std::vector<Level> levels;  // finest first
};

// Builds a Policy from parsed lod.json. Checks the format, that there is at least one level, and
// that switch distances increase and coverages decrease; on failure returns false with `error`
// naming the field.
inline bool policyFromJson(const JsonValue& root, Policy& policy, std::string* error) {
  auto fail = [&](const std::string& reason) {
    if (error) *error = reason;
    return false;
  };
  if (!root.isObject()) return fail("lod.json: the top level must be an object");
  const JsonValue* format = root.find("format");
  if (!format || format->string() != "duolod-lod")
    return fail("lod.json: \"format\" must be \"duolod-lod\"");
  const JsonValue* version = root.find("version");
  if (!version || version->number(-1) != 1)
    return fail("lod.json: unsupported \"version\" (expected 1)");
  const JsonValue* levels = root.find("levels");
  if (!levels || !levels->isArray() || levels->items().empty())
    return fail("lod.json: \"levels\" must be a non-empty array");
  Policy parsed;
  for (size_t i = 0; i < levels->items().size(); ++i) {
    const JsonValue& entry = levels->items()[i];
    std::string where = "lod.json: levels[" + std::to_string(i) + "]";
    if (!entry.isObject()) return fail(where + " must be an object");
    const JsonValue* distance = entry.find("switch_distance");
    const JsonValue* coverage = entry.find("screen_coverage");
    if (!distance || !distance->isNumber() || !std::isfinite(distance->number()) ||
        distance->number() < 0)
      return fail(where + ".switch_distance must be a non-negative number");
    if (!coverage || !coverage->isNumber() || !(coverage->number() >= 0 && coverage->number() <= 1))
      return fail(where + ".screen_coverage must be a number in [0, 1]");
    Level level;
    level.switch_distance = distance->number();
    level.screen_coverage = coverage->number();
    // Numbers are range-checked before they are converted (a float beyond an integer's range
    // is undefined behaviour to convert).
    if (const JsonValue* triangles = entry.find("triangles")) {
      if (!triangles->isNumber() || !(triangles->number() >= 0 && triangles->number() <= 1e15))
        return fail(where + ".triangles must be a count");
      level.triangles = static_cast<uint64_t>(triangles->number());
    }
    if (const JsonValue* mesh = entry.find("mesh")) {
      if (!mesh->isString()) return fail(where + ".mesh must be a string");
      level.mesh = mesh->string();
    }
    if (const JsonValue* shader = entry.find("shader")) {
      if (const JsonValue* summary = shader->find("summary"))
        level.shader_summary = summary->string();
      if (const JsonValue* files = shader->find("files"))
        for (const auto& [kind, file] : files->members()) level.shader_files[kind] = file.string();
      if (const JsonValue* parameters = shader->find("parameters")) {
        for (const JsonValue& item : parameters->items()) {
          Level::Parameter parameter;
          if (const JsonValue* name = item.find("name")) parameter.name = name->string();
          const JsonValue* location = item.find("location");
          const JsonValue* value = item.find("value");
          if (!location || !location->isNumber() || !value || !value->isArray() ||
              value->items().empty() || value->items().size() > 4)
            return fail(where + ".shader.parameters: each needs a location and 1-4 values");
          const double at = location->number();
          if (!(at >= 0 && at < 65536 && at == std::floor(at)))
            return fail(where +
                        ".shader.parameters: a location must be a whole number in [0, 65535]");
          parameter.location = static_cast<int>(at);
          for (const JsonValue& component : value->items()) {
            // A value written as null (a NaN) or out of float's range is not silently 0 or inf.
            const double number = component.number(NAN);
            if (!component.isNumber() || !std::isfinite(static_cast<float>(number)))
              return fail(where + ".shader.parameters: values must be finite numbers");
            parameter.value.push_back(static_cast<float>(number));
          }
          level.shader_parameters.push_back(std::move(parameter));
        }
      }
    }
    if (!parsed.levels.empty()) {
      const Level& previous = parsed.levels.back();
      if (!(level.switch_distance > previous.switch_distance))
        return fail(where + ".switch_distance must be larger than the previous level's");
      if (level.screen_coverage > previous.screen_coverage)
        return fail(where + ".screen_coverage must not exceed the previous level's");
    }
    parsed.levels.push_back(std::move(level));
  }
  policy = std::move(parsed);
  return true;
}

inline bool parsePolicy(std::string_view json_text, Policy& policy, std::string* error) {
  JsonValue root;
  std::string parse_error;
  if (!JsonValue::parse(json_text, root, &parse_error)) {
    if (error) *error = "lod.json: " + parse_error;
    return false;
  }
  return policyFromJson(root, policy, error);
}

inline bool loadPolicy(const std::string& path, Policy& policy, std::string* error) {
  std::ifstream file(path, std::ios::binary);
  if (!file) {
    if (error) *error = path + ": cannot open";
    return false;
  }
  std::stringstream text;
  text << file.rdbuf();
  if (!parsePolicy(text.str(), policy, error)) {
    if (error) *error = path + ": " + *error;
    return false;
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// Level selection.

struct SelectorOptions {
  // Relative hysteresis band: moving away, level k is taken once the distance passes
  // switch_distance_k·(1 + hysteresis); coming closer, it is left once the distance falls under
  // switch_distance_k·(1 − hysteresis). 0 = switch exactly at the thresholds.
  double hysteresis = 0.05;
  // Relative half-width of the cross-fade band around each switch distance: within
  // [s_k·(1 − fade_band), s_k·(1 + fade_band)] levels k−1 and k are blended (a band reaches at
  // most half-way to the next switch). 0 = no cross-fade. With a band, what is seen depends on
  // the distance alone; the hysteresis only picks which of two blended levels is `level`.
  double fade_band = 0;
  // Both are taken in [0, 0.99]: a value outside is clamped into it, NaN is 0.
};

struct Selection {
  int level = 0;        // the level to draw
  int fade_level = -1;  // the level to blend in (dithered), or -1
  float fade = 0;       // weight of fade_level in [0, 1]; the drawn level takes 1 − fade
};

class LevelSelector {
 public:
  explicit LevelSelector(Policy policy, SelectorOptions options = {})
      : policy_(std::move(policy)), options_(sanitized(options)) {}

  const Policy& policy() const { return policy_; }
  const SelectorOptions& options() const { return options_; }
  int currentLevel() const { return current_; }

  // Selection for a camera at `distance` from the object (the units of lod.json). A NaN distance
  // keeps the current level.
  Selection selectByDistance(double distance) {
    return select(distance, [this](size_t k) { return policy_.levels[k].switch_distance; });
  }
  // Selection for an object covering `coverage` of the screen area. Projected area falls with the
  // square of the distance, so 1/sqrt(coverage) plays the role of distance and the bands mean the
  // same in both modes. A NaN coverage keeps the current level.
  Selection selectByScreenCoverage(double coverage) {
    auto farness = [](double c) {
      return std::isnan(c) ? NAN : c > 0 ? 1.0 / std::sqrt(c) : INFINITY;
    };
    return select(farness(coverage),
                  [&](size_t k) { return farness(policy_.levels[k].screen_coverage); });
  }

 private:
  static SelectorOptions sanitized(SelectorOptions options) {
    auto band = [](double value) { return std::isnan(value) ? 0.0 : std::clamp(value, 0.0, 0.99); };
    return {.hysteresis = band(options.hysteresis), .fade_band = band(options.fade_band)};
  }

  template <class Threshold>
  Selection select(double farness, const Threshold& threshold) {
    const size_t count = policy_.levels.size();
    if (count == 0 || std::isnan(farness)) return {.level = current_};
    // Thresholds increase with k. `entered` counts levels whose far side has been passed with the
    // band; `allowed` counts those not yet left with the band. entered <= allowed.
    int entered = 0, allowed = 0;
    for (size_t k = 1; k < count; ++k) {
      if (farness >= threshold(k) * (1 + options_.hysteresis)) entered = static_cast<int>(k);
      if (farness >= threshold(k) * (1 - options_.hysteresis)) allowed = static_cast<int>(k);
    }
    current_ = std::clamp(current_, entered, allowed);
    Selection selection{.level = current_};
    if (options_.fade_band <= 0) return selection;
    // What is seen is a function of the distance alone, so that it never jumps: levels k−1 and k
    // blend across the band around s_k (narrowed to half the gap to a neighbouring switch, so
    // that bands never overlap), and elsewhere the level whose range holds the distance is seen.
    // The hysteresis cannot hold a level that is not seen: it then moves to the one that is (with
    // a fade band the blend is what stops popping), and holds between the two blended levels.
    int seen_near = 0, seen_far = -1;
    float weight_far = 0;  // of seen_far
    for (size_t k = 1; k < count; ++k) {
      const double s = threshold(k);
      double low = s * (1 - options_.fade_band), high = s * (1 + options_.fade_band);
      low = std::max(low, s - 0.5 * (s - threshold(k - 1)));
      if (k + 1 < count) high = std::min(high, s + 0.5 * (threshold(k + 1) - s));
      if (farness >= high) {
        seen_near = static_cast<int>(k);
        continue;
      }
      if (farness > low) {
        seen_near = static_cast<int>(k) - 1;
        seen_far = static_cast<int>(k);
        // Weight of level k rises from 0 at `low` to 1 at `high`.
        weight_far = static_cast<float>((farness - low) / (high - low));
      }
      break;
    }
    if (seen_far < 0) {
      current_ = seen_near;
      return {.level = current_};
    }
    if (current_ != seen_near && current_ != seen_far)
      current_ = weight_far >= 0.5f ? seen_far : seen_near;
    if (current_ == seen_near) return {current_, seen_far, weight_far};
    return {current_, seen_near, 1.0f - weight_far};
  }

  Policy policy_;
  SelectorOptions options_;
  int current_ = 0;
};

}  // namespace duolod::runtime
