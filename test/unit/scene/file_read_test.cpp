// Bounded input files: regular files only, within a size limit, with the path in every message.
#include "corde_sim/io/file_read.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

namespace corde {
namespace {

std::string temp_path(const std::string& name) {
  return "/tmp/corde_file_read_" + std::to_string(getpid()) + "_" + name;
}

std::string message_of(const std::string& path, long limit) {
  try {
    read_input_file(path, "scene file", limit);
  } catch (const FileError& e) {
    return e.what();
  }
  return "";
}

TEST(FileRead, ReadsARegularFileWithinTheLimit) {
  const std::string p = temp_path("ok");
  std::ofstream(p) << "name: x\n";
  EXPECT_EQ(read_input_file(p, "scene file", 100), "name: x\n");
  EXPECT_EQ(check_input_file(p, "scene file", 100), "");
  std::remove(p.c_str());
}

TEST(FileRead, RefusesAFifoWithoutBlocking) {
  const std::string p = temp_path("fifo");
  ASSERT_EQ(mkfifo(p.c_str(), 0600), 0);
  const std::string m = message_of(p, 100);
  EXPECT_NE(m.find(p), std::string::npos) << m;
  EXPECT_NE(m.find("not a regular file"), std::string::npos) << m;
  std::remove(p.c_str());
}

TEST(FileRead, RefusesDevicesDirectoriesMissingAndEmptyPaths) {
  EXPECT_NE(message_of("/dev/zero", 100).find("not a regular file"), std::string::npos);
  EXPECT_NE(message_of("/tmp", 100).find("is a directory"), std::string::npos);
  EXPECT_NE(message_of("/nonexistent/x.yaml", 100).find("cannot open"), std::string::npos);
  EXPECT_NE(message_of("", 100).find("path is empty"), std::string::npos);
}

TEST(FileRead, RefusesAFileOverTheLimitNamingSizeAndLimit) {
  const std::string p = temp_path("big");
  std::ofstream(p) << std::string(101, 'a');
  const std::string m = message_of(p, 100);
  EXPECT_NE(m.find("larger than the limit of 100 bytes for a scene file"), std::string::npos) << m;
  EXPECT_NE(m.find("101 bytes"), std::string::npos) << m;
  EXPECT_EQ(read_input_file(p, "scene file", 101).size(), 101u);
  std::remove(p.c_str());
}

}  // namespace
}  // namespace corde
