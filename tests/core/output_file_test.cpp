// Output files written atomically (core/output_file.hpp, issue 39 item 3): whole under their
// name or not there at all, the previous file untouched by a failed write, and an error that
// names the path and the system's reason. /dev/full stands for a full disk: every write to
// it fails with ENOSPC.

#include "red/core/output_file.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "../support/cli.hpp"

namespace red {
namespace {

namespace fs = std::filesystem;
using test::read_text;

fs::path fresh_dir(const std::string& name) {
  const fs::path d =
      fs::temp_directory_path() / ("red-output-file-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(WriteFileAtomically, WritesTheWholeTextAndLeavesNoPartialFile) {
  const fs::path d = fresh_dir("whole");
  const std::string path = (d / "summary.json").string();
  const std::string text(200'000, 'x');  // more than one write() may take
  ASSERT_FALSE(write_file_atomically(path, text).has_value());
  EXPECT_EQ(read_text(path), text);
  EXPECT_FALSE(fs::exists(partial_path(path)));
  // Replacing it: the new bytes, still no partial file.
  ASSERT_FALSE(write_file_atomically(path, "new\n").has_value());
  EXPECT_EQ(read_text(path), "new\n");
  EXPECT_FALSE(fs::exists(partial_path(path)));
  fs::remove_all(d);
}

TEST(WriteFileAtomically, AFullDiskLeavesThePreviousFileAndNamesTheReason) {
  const fs::path d = fresh_dir("full");
  const std::string path = (d / "summary.json").string();
  ASSERT_FALSE(write_file_atomically(path, "old\n").has_value());
  // The partial name leads to /dev/full: the write fails as on a full disk.
  fs::create_symlink("/dev/full", partial_path(path));
  const auto e = write_file_atomically(path, "new\n");
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->file, path);
  EXPECT_TRUE(contains(e->message, "write failed: No space left on device")) << e->message;
  EXPECT_EQ(read_text(path), "old\n");                               // untouched
  EXPECT_FALSE(fs::exists(fs::symlink_status(partial_path(path))));  // nothing left behind
  fs::remove_all(d);
}

TEST(WriteFileAtomically, AMissingDirectoryNamesThePathAndTheReason) {
  const fs::path d = fresh_dir("missing");
  const std::string path = (d / "no" / "such" / "summary.json").string();
  const auto e = write_file_atomically(path, "x");
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->file, path);
  EXPECT_TRUE(contains(e->message, "No such file or directory")) << e->message;
  fs::remove_all(d);
}

TEST(AtomicFile, IsRenamedIntoPlaceOnlyByCommit) {
  const fs::path d = fresh_dir("commit");
  const std::string path = (d / "trace.json").string();
  {
    AtomicFile f(path);
    f.stream() << "{\"traceEvents\": []}\n";
    f.stream().flush();
    // Before the commit the bytes are under the partial name only.
    EXPECT_FALSE(fs::exists(path));
    EXPECT_TRUE(fs::exists(partial_path(path)));
    ASSERT_FALSE(f.commit().has_value());
  }
  EXPECT_EQ(read_text(path), "{\"traceEvents\": []}\n");
  EXPECT_FALSE(fs::exists(partial_path(path)));
  {
    // Abandoned (an error elsewhere): the old file stays, the partial one goes.
    AtomicFile f(path);
    f.stream() << "half";
  }
  EXPECT_EQ(read_text(path), "{\"traceEvents\": []}\n");
  EXPECT_FALSE(fs::exists(partial_path(path)));
  fs::remove_all(d);
}

TEST(AtomicFile, AFullDiskIsAnErrorWithTheReason) {
  const fs::path d = fresh_dir("atomic-full");
  const std::string path = (d / "trace.json").string();
  fs::create_symlink("/dev/full", partial_path(path));
  AtomicFile f(path);
  // More than the buffer holds, so that some writes fail before the commit.
  for (int i = 0; i < 10'000; ++i) f.stream() << "0123456789abcdef0123456789abcdef\n";
  const auto e = f.commit();
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->file, path);
  EXPECT_TRUE(contains(e->message, "No space left on device")) << e->message;
  EXPECT_FALSE(fs::exists(path));
  fs::remove_all(d);
}

}  // namespace
}  // namespace red
