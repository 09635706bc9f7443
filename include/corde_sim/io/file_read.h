// Reading input files with bounds: only regular files (a FIFO or device would block or never
// end), at most a given size, so that a hostile or mistaken path gives a clear error at once.
#pragma once

#include <stdexcept>
#include <string>

namespace corde {

// A file that cannot be used as input. The message starts with the path.
struct FileError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Why `path` cannot be read as an input file of kind `what` ("scene file", "URDF", ...) of at
// most `max_bytes` bytes: "" when it is a readable regular file within the limit. Checks with
// stat() only, without opening the file (opening a FIFO blocks).
std::string check_input_file(const std::string& path, const std::string& what, long max_bytes);

// The whole text of the regular file `path`, after check_input_file(); throws FileError with that
// message, or when reading fails. Reads at most max_bytes + 1 bytes, so a file that grows while
// read still cannot exhaust memory.
std::string read_input_file(const std::string& path, const std::string& what, long max_bytes);

}  // namespace corde
