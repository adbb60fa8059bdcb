// A throw-away certificate authority for TLS tests: a CA, a server
// certificate for 127.0.0.1 and localhost, and a client certificate, made by
// the openssl command in a temporary directory at test time (nothing secret
// is kept in the repository).
#ifndef LANE_TESTS_COMMON_TEST_CA_H_
#define LANE_TESTS_COMMON_TEST_CA_H_

#include <string>

namespace lane::testing {

class TestCa {
 public:
  // Makes the files: ca.crt, server.crt, server.key, client.crt, client.key.
  TestCa();
  // Removes the directory.
  ~TestCa();
  TestCa(const TestCa&) = delete;
  TestCa& operator=(const TestCa&) = delete;

  // False when openssl is missing or failed; `error()` says why.
  bool ok() const { return ok_; }
  const std::string& error() const { return error_; }

  std::string Path(const std::string& name) const { return dir_ + "/" + name; }
  // The contents of one of the files ("" when missing).
  std::string Read(const std::string& name) const;

 private:
  std::string dir_;
  bool ok_ = false;
  std::string error_;
};

}  // namespace lane::testing

#endif  // LANE_TESTS_COMMON_TEST_CA_H_
