#include "red/scenario/manifest.hpp"

#include "red/core/file.hpp"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <filesystem>
#include <set>
#include <string>

namespace red {

const char* to_string(FeatureForm form) noexcept {
  switch (form) {
    case FeatureForm::Tensor:
      return "tensor";
    case FeatureForm::Tuple:
      return "tuple";
    case FeatureForm::List:
      return "list";
  }
  return "?";
}

namespace {

namespace fs = std::filesystem;

int line_of(const YAML::Node& node) {
  const YAML::Mark mark = node.Mark();
  return mark.line >= 0 ? mark.line + 1 : 0;
}

bool valid_head_name(const std::string& name) {
  if (name.empty()) return false;
  for (char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '-';
    if (!ok) return false;
  }
  return true;
}

class Parser {
 public:
  explicit Parser(std::string file) : file_(std::move(file)) {
    dir_ = fs::path(file_).parent_path();
  }

  // `text` null: read the file itself.
  Expected<ModelManifest> parse(const std::string* text) {
    YAML::Node root;
    std::string read;
    if (text == nullptr) {
      auto r = read_file(file_);
      if (!r) return Error{file_, 0, "cannot open the model manifest: " + r.error().message};
      read = std::move(*r);
      text = &read;
    }
    if (auto e = check_utf8(*text, file_)) return *e;
    try {
      root = YAML::Load(*text);
      if (const int second = second_yaml_document_line(*text); second > 0)
        return Error{file_, second, "a second YAML document: a manifest holds one"};
    } catch (const YAML::ParserException& e) {
      return Error{file_, e.mark.line >= 0 ? e.mark.line + 1 : 0, "YAML syntax error: " + e.msg};
    }
    if (root.IsNull()) return Error{file_, 0, "empty model manifest"};
    if (!root.IsMap()) {
      return Error{file_, line_of(root),
                   "a model manifest must be a mapping with the keys encoder, heads and input"};
    }
    ModelManifest m;
    m.file = file_;
    std::set<std::string> seen;
    for (const auto& entry : root) {
      const int line = line_of(entry.first);
      if (!entry.first.IsScalar()) return Error{file_, line, "keys must be plain words"};
      const std::string key = entry.first.Scalar();
      if (!seen.insert(key).second) return Error{file_, line, "key '" + key + "' given twice"};
      std::optional<Error> err;
      if (key == "encoder") {
        err = file_entry(entry.second, "encoder", "", m.encoder);
      } else if (key == "heads") {
        err = heads(entry.second, line, m);
      } else if (key == "input") {
        err = input(entry.second, m);
      } else if (key == "outputs") {
        err = outputs(entry.second, m);
      } else {
        err = Error{file_, line,
                    "unknown key '" + key + "' (expected encoder, heads, input or outputs)"};
      }
      if (err) return *err;
    }
    for (const char* key : {"encoder", "heads", "input"}) {
      if (seen.count(key) == 0) {
        return Error{file_, line_of(root), std::string("missing key '") + key + "'"};
      }
    }
    return m;
  }

 private:
  std::optional<Error> file_entry(const YAML::Node& value, const std::string& what,
                                  const std::string& name, ManifestFile& out) const {
    const int line = line_of(value);
    if (!value.IsScalar() || value.Scalar().empty()) {
      return Error{file_, line, what + " must be the path of a TorchScript file"};
    }
    const fs::path given(value.Scalar());
    const fs::path resolved = given.is_absolute() ? given : dir_ / given;
    std::error_code ec;
    if (!fs::is_regular_file(resolved, ec)) {
      return Error{file_, line,
                   what + " file '" + value.Scalar() + "' not found (looked for '" +
                       resolved.string() + "')"};
    }
    out = ManifestFile{name, resolved.string(), line};
    return std::nullopt;
  }

  std::optional<Error> heads(const YAML::Node& value, int key_line, ModelManifest& m) const {
    if (!value.IsMap() || value.size() == 0) {
      return Error{file_, value.IsNull() ? key_line : line_of(value),
                   "heads must be a non-empty mapping of head name to TorchScript file"};
    }
    std::set<std::string> names;
    for (const auto& entry : value) {
      const int line = line_of(entry.first);
      const std::string name = entry.first.IsScalar() ? entry.first.Scalar() : std::string();
      if (!valid_head_name(name)) {
        return Error{file_, line,
                     "bad head name '" + name + "' (letters, digits, '_' and '-' only)"};
      }
      if (!names.insert(name).second) {
        return Error{file_, line, "head '" + name + "' given twice"};
      }
      ManifestFile f;
      if (auto err = file_entry(entry.second, "head '" + name + "'", name, f)) return err;
      m.heads.push_back(std::move(f));
    }
    return std::nullopt;
  }

  std::optional<Error> input(const YAML::Node& value, ModelManifest& m) const {
    const int line = line_of(value);
    const Error bad{file_, line, "input must be [C, H, W], three positive integers"};
    if (!value.IsSequence() || value.size() != 3) return bad;
    m.input_line = line;
    for (const auto& v : value) {
      std::int64_t n = 0;
      try {
        n = v.as<std::int64_t>();
      } catch (const YAML::Exception&) {
        return bad;
      }
      if (n <= 0) return bad;
      m.input.push_back(n);
    }
    return std::nullopt;
  }

  std::optional<Error> outputs(const YAML::Node& value, ModelManifest& m) const {
    const int line = line_of(value);
    const std::string text = value.IsScalar() ? value.Scalar() : std::string();
    static constexpr std::array kForms{FeatureForm::Tensor, FeatureForm::Tuple, FeatureForm::List};
    for (FeatureForm f : kForms) {
      if (text == to_string(f)) {
        m.outputs = f;
        m.outputs_line = line;
        return std::nullopt;
      }
    }
    return Error{file_, line, "outputs must be tensor, tuple or list, not '" + text + "'"};
  }

  std::string file_;
  fs::path dir_;
};

}  // namespace

Expected<ModelManifest> load_manifest(const std::string& path) {
  return Parser(path).parse(nullptr);
}

Expected<ModelManifest> parse_manifest(const std::string& yaml_text, const std::string& path) {
  return Parser(path).parse(&yaml_text);
}

std::optional<Error> check_model(Scenario& s, std::optional<ModelManifest>* manifest) {
  if (manifest != nullptr) manifest->reset();
  if (s.model.manifest.empty()) return std::nullopt;
  const std::string& path = s.model.manifest;
  const int manifest_line = s.model.manifest_line > 0 ? s.model.manifest_line : s.model.line;
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {
    return Error{s.file, manifest_line,
                 fmt::format("model.manifest: the model manifest '{}' {}", path,
                             fs::exists(path, ec) ? "is not a file" : "does not exist")};
  }
  auto m = load_manifest(path);
  if (!m) return m.error();
  std::string known;
  for (const ManifestFile& h : m->heads) known += (known.empty() ? "" : ", ") + h.name;
  for (std::size_t i = 0; i < s.model.heads.size(); ++i) {
    const std::string& head = s.model.heads[i];
    const bool found = std::any_of(m->heads.begin(), m->heads.end(),
                                   [&](const ManifestFile& f) { return f.name == head; });
    if (!found) {
      const int line = i < s.model.head_lines.size() ? s.model.head_lines[i] : s.model.line;
      return Error{s.file, line,
                   fmt::format("model.heads: head '{}' is not in the model manifest '{}' (its "
                               "heads: {})",
                               head, path, known)};
    }
  }
  if (s.model.input_line > 0) {
    if (s.model.input != m->input) {
      return Error{
          s.file, s.model.input_line,
          fmt::format("model.input: {} is not the input of the model manifest '{}' "
                      "({}, line {}); give the manifest's or leave input out",
                      shape_label(s.model.input), path, shape_label(m->input), m->input_line)};
    }
  } else {
    s.model.input = m->input;
  }
  if (manifest != nullptr) *manifest = std::move(*m);
  return std::nullopt;
}

}  // namespace red
