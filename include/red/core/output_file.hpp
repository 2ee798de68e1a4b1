#pragma once
/// \file
/// Writing an output file so that it is either whole or absent under its name: the bytes go
/// to `NAME.partial` in the same directory, which is renamed over `NAME` once they are all
/// written (docs/REPORTS.md, "The output directory"). A process killed while writing leaves
/// the previous `NAME` (or none) and a visible `NAME.partial`, never a truncated `NAME`.
///
///     if (auto e = write_file_atomically("out/summary.json", text)) print_error(*e);
///
///     AtomicFile f("out/trace.json");          // f.stream() writes to out/trace.json.partial
///     write_chrome_trace(f.stream(), ...);
///     if (auto e = f.commit()) print_error(*e); // renamed to out/trace.json
///
/// No fsync: the guarantee is against the process dying (a signal, a crash), which leaves
/// what it wrote with the kernel; it is not against the machine losing power.

#include <array>
#include <optional>
#include <ostream>
#include <streambuf>
#include <string>
#include <string_view>

#include "red/core/expected.hpp"

namespace red {

/// The name a file is written under until it is complete: `path` + ".partial".
std::string partial_path(const std::string& path);

/// "REASON" of the system's error `err` (strerror), e.g. "No space left on device".
std::string system_reason(int err);

/// Writes `text` to partial_path(`path`), then renames it over `path`. Error names the path
/// and the system's reason (e.g. "write failed: No space left on device"); on an error
/// nothing is left under either name and a previous `path` is untouched.
std::optional<Error> write_file_atomically(const std::string& path, std::string_view text);

/// A file written through a stream under partial_path(`path`) and renamed to `path` by
/// commit(). Destroyed without a commit, it removes what it wrote. Not thread-safe.
class AtomicFile {
 public:
  /// Opens partial_path(`path`) for writing (an error shows in commit(); the stream then
  /// discards what it is given).
  explicit AtomicFile(std::string path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  /// Where the bytes go.
  [[nodiscard]] std::ostream& stream() { return out_; }
  /// Closes the file and renames it into place. Error (open, write or rename failed) names
  /// the path and the system's reason; the partial file is then removed.
  [[nodiscard]] std::optional<Error> commit();

 private:
  // A buffer over a file descriptor that keeps the first error's errno (std::filebuf
  // keeps none), so that commit() can name the system's reason.
  class Buffer final : public std::streambuf {
   public:
    int fd = -1;
    int error = 0;  // the first errno met, 0 while none
    Buffer() { setp(bytes_.data(), bytes_.data() + bytes_.size()); }
    bool drain();

   protected:
    int_type overflow(int_type c) override;
    int sync() override { return drain() ? 0 : -1; }

   private:
    std::array<char, 1 << 16> bytes_{};
  };

  std::string path_;
  std::string partial_;
  Buffer buffer_;
  std::ostream out_{&buffer_};
  bool done_ = false;
};

}  // namespace red
