// TLS material for the tests, made at test time by tests/support/make_test_certs.sh in a private
// temporary directory (removed afterwards): nothing is committed. Needs `openssl`
// (scripts/install-deps.sh). RBDGRAD_MAKE_TEST_CERTS must name the script.
#pragma once

#include <stdlib.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#ifndef RBDGRAD_MAKE_TEST_CERTS
#error "RBDGRAD_MAKE_TEST_CERTS must name tests/support/make_test_certs.sh"
#endif

namespace rbdgrad::testing {

class TestCertificates {
 public:
  /// Makes ca, server (127.0.0.1, localhost), client, other_ca and other_client (.pem and .key).
  /// Throws std::runtime_error when the script fails.
  TestCertificates() {
    char tmpl[] = "/tmp/rbdgrad-certs-XXXXXX";
    if (mkdtemp(tmpl) == nullptr) throw std::runtime_error("mkdtemp failed");
    dir_ = tmpl;
    const std::string command = std::string("bash '") + RBDGRAD_MAKE_TEST_CERTS + "' '" + dir_ + "'";
    if (std::system(command.c_str()) != 0) throw std::runtime_error("'" + command + "' failed");
  }
  ~TestCertificates() {
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }
  TestCertificates(const TestCertificates&) = delete;
  TestCertificates& operator=(const TestCertificates&) = delete;

  const std::string& dir() const { return dir_; }
  /// "ca.pem" -> its path
  std::string path(const std::string& file) const { return dir_ + "/" + file; }
  /// the file's contents
  std::string read(const std::string& file) const {
    std::ifstream in(path(file));
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
  }
  /// writes `text` to a file of the directory and returns its path (e.g. a tokens file)
  std::string write(const std::string& file, const std::string& text) const {
    std::ofstream(path(file)) << text;
    return path(file);
  }

 private:
  std::string dir_;
};

}  // namespace rbdgrad::testing
