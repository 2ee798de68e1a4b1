/// \file
/// The scenario loader's YAML reader (libyaml events into a tree, src/scenario/yaml_tree.cpp),
/// through parse_scenario: what it keeps of tags, nulls, lines, anchors and aliases, and
/// where it stops (nesting, the first document, syntax errors).

#include <gtest/gtest.h>

#include <string>

#include "red/scenario/loader.hpp"

namespace red {
namespace {

// A one-camera scenario around `op` (the operation's own lines, indented four spaces).
std::string with_operation(const std::string& op, const std::string& top = "") {
  return "name: yaml\nduration_s: 2\nseed: 1\ndevice: {lanes: 1}\n" + top +
         "operations:\n  - name: drive\n    rate_hz: 10\n" + op;
}

Error error_of(const std::string& yaml) {
  const Expected<Scenario> s = parse_scenario(yaml, "s.yaml");
  EXPECT_FALSE(s.has_value()) << "accepted:\n" << yaml;
  return s.has_value() ? Error{} : s.error();
}

bool mentions(const Error& e, const std::string& fragment) {
  return e.message.find(fragment) != std::string::npos;
}

TEST(YamlReader, TagsTellNumbersFromStrings) {
  // Plain and !!float scalars are numbers; quoted and !!str ones are strings, and the message
  // says which it got.
  ASSERT_TRUE(parse_scenario(
      with_operation("    deadline_ms: !!float 50\n    nodes: {a: {cost_ms: 1}}\n"), "s.yaml"));
  const Error quoted =
      error_of(with_operation("    deadline_ms: '50'\n    nodes: {a: {cost_ms: 1}}\n"));
  EXPECT_EQ(quoted.line, 8);
  EXPECT_TRUE(mentions(quoted, "got the quoted string '50'")) << quoted.to_string();
  const Error str =
      error_of(with_operation("    deadline_ms: !!str 50\n    nodes: {a: {cost_ms: 1}}\n"));
  EXPECT_TRUE(mentions(str, "got the string !!str '50'")) << str.to_string();
}

TEST(YamlReader, NullsAreEmptyTildeOrNull) {
  for (const char* null : {"", " ~", " null", " Null", " NULL"}) {
    const Error e = error_of(with_operation(std::string("    deadline_ms:") + null +
                                            "\n    nodes: {a: {cost_ms: 1}}\n"));
    EXPECT_EQ(e.line, 8) << null;  // a null value is reported on its key's line
    EXPECT_TRUE(mentions(e, "got nothing")) << null << ": " << e.to_string();
  }
  // Quoted, "null" is a string.
  const Error quoted =
      error_of(with_operation("    deadline_ms: 'null'\n    nodes: {a: {cost_ms: 1}}\n"));
  EXPECT_TRUE(mentions(quoted, "got the quoted string 'null'")) << quoted.to_string();
}

TEST(YamlReader, LinesOfNestedValues) {
  const Error e = error_of(with_operation(
      "    deadline_ms: 50\n    nodes:\n      a: {cost_ms: 1}\n      b:\n        cost_ms: -2\n"));
  EXPECT_EQ(e.line, 12) << e.to_string();
  const Error edge =
      error_of(with_operation("    deadline_ms: 50\n    nodes: {a: {cost_ms: 1}}\n    edges:\n"
                              "      - [a, z]\n"));
  EXPECT_EQ(edge.line, 11) << edge.to_string();
  EXPECT_TRUE(mentions(edge, "refers to node 'z'")) << edge.to_string();
}

TEST(YamlReader, AnAliasIsTheAnchoredValue) {
  const auto s = parse_scenario(
      "name: yaml\nduration_s: 2\nseed: 1\ndevice: {lanes: 1}\n"
      "operations:\n"
      "  - name: one\n    rate_hz: 10\n    deadline_ms: 50\n"
      "    nodes: &graph {a: {cost_ms: 1}, b: {cost_ms: 2}}\n    edges: &edges [[a, b]]\n"
      "  - name: two\n    rate_hz: 5\n    deadline_ms: 80\n    nodes: *graph\n    edges: *edges\n",
      "s.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().to_string();
  ASSERT_EQ(s->operation_count(), 2);
  const OperationSpec& two = *s->initial[1];
  ASSERT_EQ(two.nodes.size(), 2U);
  EXPECT_EQ(two.nodes[1].name, "b");
  ASSERT_EQ(two.edges.size(), 1U);
  EXPECT_EQ(two.edges[0].from, 0);
  EXPECT_EQ(two.edges[0].to, 1);
}

TEST(YamlReader, UnknownAndSelfReferringAnchorsAreErrors) {
  const Error unknown = error_of(with_operation("    deadline_ms: *nothing\n"));
  EXPECT_EQ(unknown.line, 8) << unknown.to_string();
  EXPECT_TRUE(mentions(unknown, "unknown anchor 'nothing'")) << unknown.to_string();
  // An anchor is known once its node ends, so no value contains itself.
  const Error self = error_of(with_operation("    nodes: &n {a: *n}\n"));
  EXPECT_TRUE(mentions(self, "unknown anchor 'n'")) << self.to_string();
}

TEST(YamlReader, AliasBombsCostNothing) {
  // Nine levels of nine aliases: 387 million leaves if copied; shared, it is a few nodes,
  // refused as a wrong value.
  std::string yaml = "a0: &a0 [x, x, x, x, x, x, x, x, x]\n";
  for (int i = 1; i < 10; ++i) {
    std::string prev = "*a" + std::to_string(i - 1);
    yaml += "a" + std::to_string(i) + ": &a" + std::to_string(i) + " [";
    for (int k = 0; k < 9; ++k) yaml += (k ? ", " : "") + prev;
    yaml += "]\n";
  }
  const Error e = error_of(yaml + "name: *a9\n");
  EXPECT_TRUE(mentions(e, "unknown key 'a0'")) << e.to_string();
}

TEST(YamlReader, NestingIsBounded) {
  std::string deep = with_operation("    deadline_ms: 50\n    nodes: {a: {cost_ms: 1}}\n") +
                     "x: " + std::string(100, '[') + std::string(100, ']') + "\n";
  const Error e = error_of(deep);
  EXPECT_TRUE(mentions(e, "nested deeper than 64")) << e.to_string();
  EXPECT_EQ(e.line, 10) << e.to_string();
}

TEST(YamlReader, OnlyTheFirstDocumentIsRead) {
  // A syntax error in a second document is not reported as one: the second document is.
  const Error e =
      error_of(with_operation("    deadline_ms: 50\n    nodes: {a: {cost_ms: 1}}\n") + "---\n{[\n");
  EXPECT_EQ(e.line, 10) << e.to_string();
  EXPECT_TRUE(mentions(e, "a second YAML document")) << e.to_string();
}

TEST(YamlReader, SyntaxErrorsSayWhereTheConstructBegan) {
  const Error e =
      error_of(with_operation("    deadline_ms: 50\n    nodes: {a: {cost_ms: 1}\n"
                              "    edges: []\n"));
  EXPECT_EQ(e.line, 10) << e.to_string();
  EXPECT_TRUE(mentions(e, "YAML syntax error: did not find expected ',' or '}'")) << e.to_string();
  EXPECT_TRUE(mentions(e, "flow mapping that began at line 9")) << e.to_string();
  // A control character is refused on its own line.
  const Error control = error_of("name: a\nduration_s: 2\nx: \"a\x01\"\n");
  EXPECT_EQ(control.line, 3) << control.to_string();
  EXPECT_TRUE(mentions(control, "YAML syntax error")) << control.to_string();
}

TEST(YamlReader, EmptyAndCommentOnlyFilesAreEmpty) {
  for (const char* text : {"", "# nothing here\n", "---\n", "~\n"}) {
    const Error e = error_of(text);
    EXPECT_TRUE(mentions(e, "the file is empty")) << text << ": " << e.to_string();
  }
}

}  // namespace
}  // namespace red
