// Bounded reading of input files (scene, keyframe CSV, URDF, mesh).
#include "corde_sim/io/file_read.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace corde {

std::string check_input_file(const std::string& path, const std::string& what, long max_bytes) {
  if (path.empty()) return "the " + what + " path is empty";
  struct stat st;
  if (stat(path.c_str(), &st) != 0)
    return path + ": cannot open the " + what + " (" + std::strerror(errno) + ")";
  if (S_ISDIR(st.st_mode)) return path + ": is a directory, not a " + what;
  if (!S_ISREG(st.st_mode))
    return path + ": is not a regular file (a FIFO, socket or device), not a " + what;
  if (st.st_size > max_bytes)
    return path + ": larger than the limit of " + std::to_string(max_bytes) + " bytes for a " +
           what + " (" + std::to_string(static_cast<long long>(st.st_size)) + " bytes)";
  return "";
}

std::string read_input_file(const std::string& path, const std::string& what, long max_bytes) {
  const std::string why = check_input_file(path, what, max_bytes);
  if (!why.empty()) throw FileError(why);
  // O_NONBLOCK: should the path be swapped for a FIFO after the check, open() does not wait.
  const int fd = open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0)
    throw FileError(path + ": cannot open the " + what + " (" + std::strerror(errno) + ")");
  std::string text(static_cast<size_t>(max_bytes) + 1, '\0');
  size_t got = 0;
  while (got < text.size()) {
    const ssize_t n = read(fd, &text[got], text.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const std::string err = std::strerror(errno);
      close(fd);
      throw FileError(path + ": cannot read the " + what + " (" + err + ")");
    }
    if (n == 0) break;
    got += static_cast<size_t>(n);
  }
  close(fd);
  if (got > static_cast<size_t>(max_bytes))
    throw FileError(path + ": larger than the limit of " + std::to_string(max_bytes) +
                    " bytes for a " + what);
  text.resize(got);
  return text;
}

}  // namespace corde
