/// \file
/// libyaml's events into a tree (yaml_tree.hpp).

#include "yaml_tree.hpp"

#include <yaml.h>

#include <algorithm>
#include <string>
#include <unordered_map>

#include <fmt/format.h>

namespace red::yaml {

namespace {

const std::string kEmpty;

/// yaml-cpp's rule for a null: an untagged plain scalar that is empty, "~" or a spelling of
/// "null".
bool is_null_text(std::string_view s) {
  return s.empty() || s == "~" || s == "null" || s == "Null" || s == "NULL";
}

/// The parser and the current event, released on every path out.
class Parser {
 public:
  explicit Parser(std::string_view text) {
    yaml_parser_initialize(&parser_);
    yaml_parser_set_input_string(&parser_, reinterpret_cast<const unsigned char*>(text.data()),
                                 text.size());
  }
  Parser(const Parser&) = delete;
  Parser& operator=(const Parser&) = delete;
  ~Parser() {
    release();
    yaml_parser_delete(&parser_);
  }

  /// The next event, or false on a syntax error.
  bool next() {
    release();
    have_event_ = yaml_parser_parse(&parser_, &event_) != 0;
    return have_event_;
  }
  [[nodiscard]] const yaml_event_t& event() const noexcept { return event_; }

  /// The error after next() returned false: the 1-based line and what is wrong.
  [[nodiscard]] Error error(std::string_view text) const {
    std::string message = parser_.problem != nullptr ? parser_.problem : "unreadable input";
    int line = static_cast<int>(parser_.problem_mark.line) + 1;
    if (parser_.error == YAML_READER_ERROR) {
      // Reader errors carry a byte offset, not a mark.
      const std::size_t at = std::min(parser_.problem_offset, text.size());
      line = 1 +
             static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n'));
    } else if (parser_.context != nullptr) {
      message += fmt::format(" ({} that began at line {})", parser_.context,
                             parser_.context_mark.line + 1);
    }
    return Error{"", line, "YAML syntax error: " + message};
  }

 private:
  void release() {
    if (have_event_) yaml_event_delete(&event_);
    have_event_ = false;
  }

  yaml_parser_t parser_{};
  yaml_event_t event_{};
  bool have_event_ = false;
};

std::string text_of(const yaml_char_t* s) {
  return s != nullptr ? std::string(reinterpret_cast<const char*>(s)) : std::string{};
}

}  // namespace

Kind Node::kind() const noexcept {
  return data_ != nullptr ? data_->kind : Kind::Null;
}

const std::string& Node::scalar() const noexcept {
  return data_ != nullptr ? data_->scalar : kEmpty;
}

const std::string& Node::tag() const noexcept {
  return data_ != nullptr ? data_->tag : kEmpty;
}

int Node::line() const noexcept {
  return data_ != nullptr ? data_->line : 0;
}

std::size_t Node::size() const noexcept {
  if (data_ == nullptr) return 0;
  return data_->kind == Kind::Map ? data_->entries.size() : data_->items.size();
}

std::span<const Node> Node::items() const noexcept {
  if (data_ == nullptr) return {};
  return data_->items;
}

std::span<const std::pair<Node, Node>> Node::entries() const noexcept {
  if (data_ == nullptr) return {};
  return data_->entries;
}

Node Node::find(std::string_view key) const noexcept {
  for (const auto& [k, v] : entries())
    if (k.is_scalar() && k.scalar() == key) return v;
  return Node{};
}

Expected<Document> parse(std::string_view text, int max_depth) {
  Document doc;
  Parser parser(text);
  // The collections being read, innermost last, with a mapping's key waiting for its value.
  struct Open {
    NodeData* node;
    Node key;
    std::string anchor;  // known once the collection ends
  };
  std::vector<Open> open;
  std::unordered_map<std::string, const NodeData*> anchors;

  const auto make = [&doc](Kind kind, const yaml_mark_t& mark) {
    NodeData& n = doc.nodes_->emplace_back();
    n.kind = kind;
    n.line = static_cast<int>(mark.line) + 1;
    return &n;
  };
  // A finished node goes into the innermost open collection, or becomes the root.
  const auto place = [&](const NodeData* n) {
    if (open.empty()) {
      doc.root_ = Node{n};
      return;
    }
    Open& o = open.back();
    if (o.node->kind == Kind::Sequence) {
      o.node->items.emplace_back(n);
    } else if (!o.key) {
      o.key = Node{n};
    } else {
      o.node->entries.emplace_back(o.key, Node{n});
      o.key = Node{};
    }
  };

  for (;;) {
    if (!parser.next()) return parser.error(text);
    const yaml_event_t& e = parser.event();
    switch (e.type) {
      case YAML_NO_EVENT:
      case YAML_STREAM_START_EVENT:
      case YAML_DOCUMENT_START_EVENT:
        break;
      case YAML_DOCUMENT_END_EVENT:
      case YAML_STREAM_END_EVENT:
        return doc;  // the first document only
      case YAML_ALIAS_EVENT: {
        const std::string name = text_of(e.data.alias.anchor);
        const auto it = anchors.find(name);
        if (it == anchors.end())
          return Error{"", static_cast<int>(e.start_mark.line) + 1,
                       "YAML syntax error: unknown anchor '" + name + "'"};
        place(it->second);
        break;
      }
      case YAML_SCALAR_EVENT: {
        const auto& s = e.data.scalar;
        const bool plain = s.style == YAML_PLAIN_SCALAR_STYLE;
        std::string value(reinterpret_cast<const char*>(s.value), s.length);
        const bool null = s.tag == nullptr && plain && is_null_text(value);
        NodeData* n = make(null ? Kind::Null : Kind::Scalar, e.start_mark);
        n->tag = s.tag != nullptr ? text_of(s.tag) : plain ? "?" : "!";
        if (!null) n->scalar = std::move(value);
        if (s.anchor != nullptr) anchors[text_of(s.anchor)] = n;
        place(n);
        break;
      }
      case YAML_SEQUENCE_START_EVENT:
      case YAML_MAPPING_START_EVENT: {
        const bool map = e.type == YAML_MAPPING_START_EVENT;
        if (static_cast<int>(open.size()) >= max_depth)
          return Error{"", static_cast<int>(e.start_mark.line) + 1,
                       fmt::format("collections nested deeper than {} levels", max_depth)};
        const yaml_char_t* tag = map ? e.data.mapping_start.tag : e.data.sequence_start.tag;
        const yaml_char_t* anchor =
            map ? e.data.mapping_start.anchor : e.data.sequence_start.anchor;
        NodeData* n = make(map ? Kind::Map : Kind::Sequence, e.start_mark);
        n->tag = tag != nullptr ? text_of(tag) : "?";
        open.push_back(Open{n, Node{}, text_of(anchor)});
        break;
      }
      case YAML_SEQUENCE_END_EVENT:
      case YAML_MAPPING_END_EVENT: {
        Open done = std::move(open.back());
        open.pop_back();
        if (!done.anchor.empty()) anchors[done.anchor] = done.node;
        place(done.node);
        break;
      }
    }
  }
}

}  // namespace red::yaml
