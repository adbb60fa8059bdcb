#include "test_ca.h"

#include <stdlib.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace lane::testing {

TestCa::TestCa() {
  if (std::system("openssl version > /dev/null 2>&1") != 0) {
    error_ = "the openssl command is missing";
    return;
  }
  char pattern[] = "/tmp/lane_tls_XXXXXX";
  if (mkdtemp(pattern) == nullptr) {
    error_ = "mkdtemp failed";
    return;
  }
  dir_ = pattern;
  // P-256 keys, valid for two days; the server certificate names the
  // loopback address and localhost.
  const std::string key = " -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes";
  const std::string script =
      "cd '" + dir_ + "' && " + "openssl req -x509" + key +
      " -keyout ca.key -out ca.crt -days 2 -subj /CN=lane-test-ca && " + "openssl req" + key +
      " -keyout server.key -out server.csr -subj /CN=localhost && " +
      "printf 'subjectAltName=IP:127.0.0.1,DNS:localhost\\n' > server.ext && " +
      "openssl x509 -req -in server.csr -CA ca.crt -CAkey ca.key -CAcreateserial"
      " -out server.crt -days 2 -extfile server.ext && " +
      "openssl req" + key + " -keyout client.key -out client.csr -subj /CN=lane-test-client && " +
      "openssl x509 -req -in client.csr -CA ca.crt -CAkey ca.key -CAcreateserial"
      " -out client.crt -days 2";
  ok_ = std::system(("(" + script + ") > '" + dir_ + "/openssl.log' 2>&1").c_str()) == 0;
  if (!ok_) error_ = "openssl failed: " + Read("openssl.log");
}

TestCa::~TestCa() {
  if (dir_.empty()) return;
  std::error_code ec;
  std::filesystem::remove_all(dir_, ec);
}

std::string TestCa::Read(const std::string& name) const {
  std::ifstream in(Path(name));
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace lane::testing
