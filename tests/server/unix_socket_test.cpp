// Tests for server/unix_socket.cpp: stale sockets are freed, live ones never taken over.
#include "unix_socket.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstring>
#include <fstream>
#include <string>

namespace rbdgrad::server {
namespace {

using ::testing::HasSubstr;

std::string test_path(const char* what) { return "/tmp/rbdgrad_ut_" + std::to_string(getpid()) + "_" + what; }

// A socket bound at path; listening or not. Closed (the file stays) by close_fd.
int bind_socket(const std::string& path, bool listening) {
  const int fd = socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, path.c_str(), sizeof(addr.sun_path) - 1);
  if (bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) return -1;
  if (listening && listen(fd, 1) != 0) return -1;
  return fd;
}

TEST(UnixSocket, NothingThereIsFree) { EXPECT_TRUE(free_unix_socket_path(test_path("none")).is_ok()); }

TEST(UnixSocket, AStaleSocketIsRemoved) {
  const std::string path = test_path("stale");
  const int fd = bind_socket(path, false);
  ASSERT_GE(fd, 0);
  close(fd);  // the file stays behind, as after a crash
  ASSERT_NE(socket_inode(path), 0u);
  EXPECT_TRUE(free_unix_socket_path(path).is_ok());
  EXPECT_EQ(socket_inode(path), 0u);
}

TEST(UnixSocket, ALiveSocketIsNeverTakenOver) {
  const std::string path = test_path("live");
  const int fd = bind_socket(path, true);
  ASSERT_GE(fd, 0);
  const Status s = free_unix_socket_path(path);
  EXPECT_EQ(s.code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(s.message(), "unix socket '" + path + "' is in use by another process");
  EXPECT_NE(socket_inode(path), 0u);
  close(fd);
  unlink(path.c_str());
}

TEST(UnixSocket, ARegularFileIsLeftAlone) {
  const std::string path = test_path("file");
  std::ofstream(path) << "data";
  const Status s = free_unix_socket_path(path);
  EXPECT_EQ(s.code(), StatusCode::kFailedPrecondition);
  EXPECT_THAT(s.message(), HasSubstr("exists and is not a socket"));
  unlink(path.c_str());
  EXPECT_EQ(free_unix_socket_path(std::string(200, 'x')).code(), StatusCode::kInvalidArgument);
}

TEST(UnixSocket, RemovesOnlyItsOwnSocket) {
  const std::string path = test_path("own");
  int fd = bind_socket(path, true);
  ASSERT_GE(fd, 0);
  const ino_t ours = socket_inode(path);
  close(fd);
  unlink(path.c_str());
  // another daemon's socket at the same path since
  fd = bind_socket(path, true);
  ASSERT_GE(fd, 0);
  if (socket_inode(path) != ours) {
    EXPECT_FALSE(remove_own_socket(path, ours));
  }
  EXPECT_TRUE(remove_own_socket(path, socket_inode(path)));
  EXPECT_EQ(socket_inode(path), 0u);
  close(fd);
}

}  // namespace
}  // namespace rbdgrad::server
