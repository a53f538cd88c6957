// Tests for server/ready_file.cpp.
#include "ready_file.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace rbdgrad::server {
namespace {

TEST(ReadyFile, WritesOneAddressPerLineAndNoTemporaryFile) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("rbdgrad_ready_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "ready").string();
  ASSERT_TRUE(write_ready_file(path, {{"tcp", "127.0.0.1:41234"}, {"unix", "/tmp/x.sock"}}).is_ok());
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(), "tcp 127.0.0.1:41234\nunix /tmp/x.sock\n");
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), std::filesystem::directory_iterator()), 1);
  std::filesystem::remove_all(dir);
}

TEST(ReadyFile, AnUnwritableDirectoryIsAnError) {
  const Status s = write_ready_file("/nonexistent/dir/ready", {{"tcp", "127.0.0.1:1"}});
  EXPECT_EQ(s.code(), StatusCode::kNotFound);
}

TEST(ListenAddress, TextAndTarget) {
  EXPECT_EQ((ListenAddress{"unix", "/tmp/a.sock"}).target(), "unix:/tmp/a.sock");
  EXPECT_EQ((ListenAddress{"tcp", "127.0.0.1:5"}).target(), "127.0.0.1:5");
  EXPECT_EQ((ListenAddress{"tcp", "127.0.0.1:5"}).text(), "tcp 127.0.0.1:5");
}

}  // namespace
}  // namespace rbdgrad::server
