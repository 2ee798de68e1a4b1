#pragma once
/// \file
/// A YAML document read into a tree by libyaml's event parser: what the scenario loader walks.
/// Internal to the loader.
///
/// Why not yaml-cpp's YAML::Load, which the rest of RED uses for small files: a scenario may
/// hold 50,000 nodes and edges, and yaml-cpp's scanner took 0.78 s of the 1.2 s that
/// `red validate` spent on such a chain; libyaml, the C library behind PyYAML's fast loader,
/// parses the same 2.7 MB in 0.12 s (docs/journal/decision-and-simulator.md, "Issue 39 item 7").
///
/// The tree keeps what the loader's messages need: each node's line, its tag as yaml-cpp
/// spells it ("?" for an untagged plain scalar, "!" for an untagged quoted one, else the
/// resolved tag, e.g. "tag:yaml.org,2002:str" for `!!str`), and mappings in file order with
/// duplicate keys kept (the loader reports them). An alias is the node its anchor named, not a
/// copy, so an "alias bomb" costs no memory; an anchor is known from the end of its node on,
/// so no node contains itself.

#include <cstdint>
#include <deque>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "red/core/expected.hpp"

namespace red::yaml {

enum class Kind : std::uint8_t { Null, Scalar, Sequence, Map };

struct NodeData;

/// A node of a Document, or nothing (what find() gives for an absent key). Cheap to copy;
/// valid while its Document lives.
class Node {
 public:
  Node() = default;
  explicit Node(const NodeData* data) noexcept : data_(data) {}

  /// False for "nothing".
  explicit operator bool() const noexcept { return data_ != nullptr; }

  [[nodiscard]] Kind kind() const noexcept;
  [[nodiscard]] bool is_null() const noexcept { return kind() == Kind::Null; }
  [[nodiscard]] bool is_scalar() const noexcept { return kind() == Kind::Scalar; }
  [[nodiscard]] bool is_sequence() const noexcept { return kind() == Kind::Sequence; }
  [[nodiscard]] bool is_map() const noexcept { return kind() == Kind::Map; }

  /// A scalar's text; empty for anything else (a null's "~" included).
  [[nodiscard]] const std::string& scalar() const noexcept;
  /// "?" (plain, untagged), "!" (quoted, untagged) or the resolved tag; empty for nothing.
  [[nodiscard]] const std::string& tag() const noexcept;
  /// 1-based line where the node starts; 0 for nothing.
  [[nodiscard]] int line() const noexcept;

  /// A sequence's items or a mapping's entries; 0 for anything else.
  [[nodiscard]] std::size_t size() const noexcept;
  /// A sequence's items (empty for anything else).
  [[nodiscard]] std::span<const Node> items() const noexcept;
  /// A mapping's entries in file order (empty for anything else).
  [[nodiscard]] std::span<const std::pair<Node, Node>> entries() const noexcept;
  /// The value of a mapping's first entry whose key is the scalar `key`, or nothing.
  [[nodiscard]] Node find(std::string_view key) const noexcept;

 private:
  const NodeData* data_ = nullptr;
};

struct NodeData {
  Kind kind = Kind::Null;
  int line = 0;
  std::string tag;
  std::string scalar;
  std::vector<Node> items;
  std::vector<std::pair<Node, Node>> entries;
};

/// A parsed document; owns its nodes.
class Document {
 public:
  /// The top-level node; nothing for a stream without a document (empty, or comments only).
  [[nodiscard]] Node root() const noexcept { return root_; }

 private:
  friend Expected<Document> parse(std::string_view text, int max_depth);
  // A deque keeps every node where it is as the document grows; the pointer keeps them there
  // when the Document moves.
  std::unique_ptr<std::deque<NodeData>> nodes_ = std::make_unique<std::deque<NodeData>>();
  Node root_;
};

/// Parses the first document of `text` (what follows it is not read: the loader refuses a
/// second document by itself). Errors carry no file name, the 1-based line, and libyaml's
/// description ("YAML syntax error: did not find expected key (while parsing a block mapping
/// that began at line 3)"); collections nested deeper than `max_depth` are an error too.
Expected<Document> parse(std::string_view text, int max_depth);

}  // namespace red::yaml
