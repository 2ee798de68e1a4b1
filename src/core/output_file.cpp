#include "red/core/output_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <utility>

namespace red {

std::string partial_path(const std::string& path) {
  return path + ".partial";
}

std::string system_reason(int err) {
  return std::strerror(err);
}

namespace {

// Renames `from` over `to`; an Error naming `to` on failure (`from` is then removed).
std::optional<Error> rename_into_place(const std::string& from, const std::string& to) {
  if (std::rename(from.c_str(), to.c_str()) == 0) return std::nullopt;
  const int err = errno;
  ::unlink(from.c_str());
  return Error{to, 0, "cannot rename " + from + " into place: " + system_reason(err)};
}

}  // namespace

std::optional<Error> write_file_atomically(const std::string& path, std::string_view text) {
  const std::string partial = partial_path(path);
  // O_TRUNC, not O_EXCL: a NAME.partial left by a killed run is overwritten.
  const int fd = ::open(partial.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return Error{path, 0, "cannot open for writing: " + system_reason(errno)};
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : EIO;
      ::close(fd);
      ::unlink(partial.c_str());
      return Error{path, 0, "write failed: " + system_reason(err)};
    }
    done += static_cast<std::size_t>(n);
  }
  // close() can report a delayed write error (NFS, some full file systems).
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(partial.c_str());
    return Error{path, 0, "write failed: " + system_reason(err)};
  }
  return rename_into_place(partial, path);
}

bool AtomicFile::Buffer::drain() {
  const char* p = pbase();
  while (p < pptr() && error == 0 && fd >= 0) {
    const ssize_t n = ::write(fd, p, static_cast<std::size_t>(pptr() - p));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      error = n < 0 ? errno : EIO;
      break;
    }
    p += n;
  }
  // After an error the bytes are dropped: the file is not renamed into place.
  setp(bytes_.data(), bytes_.data() + bytes_.size());
  return error == 0;
}

AtomicFile::Buffer::int_type AtomicFile::Buffer::overflow(int_type c) {
  if (!drain()) return traits_type::eof();
  if (!traits_type::eq_int_type(c, traits_type::eof())) {
    *pptr() = traits_type::to_char_type(c);
    pbump(1);
  }
  return traits_type::not_eof(c);
}

AtomicFile::AtomicFile(std::string path) : path_(std::move(path)), partial_(partial_path(path_)) {
  buffer_.fd = ::open(partial_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (buffer_.fd < 0) buffer_.error = errno;
}

AtomicFile::~AtomicFile() {
  if (done_ || buffer_.fd < 0) return;
  ::close(buffer_.fd);
  ::unlink(partial_.c_str());
}

std::optional<Error> AtomicFile::commit() {
  done_ = true;
  if (buffer_.fd < 0)
    return Error{path_, 0, "cannot open for writing: " + system_reason(buffer_.error)};
  buffer_.drain();
  // close() can report a delayed write error (NFS, some full file systems).
  if (::close(buffer_.fd) != 0 && buffer_.error == 0) buffer_.error = errno;
  buffer_.fd = -1;
  if (buffer_.error != 0) {
    ::unlink(partial_.c_str());
    return Error{path_, 0, "write failed: " + system_reason(buffer_.error)};
  }
  return rename_into_place(partial_, path_);
}

}  // namespace red
