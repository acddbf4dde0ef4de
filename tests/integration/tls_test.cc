// TLS on the real server binary: the handshake with and without a trusted CA, plaintext clients
// refused by a TLS server, mutual TLS, and the server's refusal of unsafe listen setups.
// Certificates are made at test time with the openssl command line tool.
#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <string>

#include "client/lib/channel.h"
#include "client/lib/health_client.h"
#include "storage/token_store.h"
#include "tests/support/server_process.h"
#include "waymark/v1/crossing.grpc.pb.h"

namespace waymark {
namespace {

using ::testing::HasSubstr;

// A CA, a server certificate for localhost/127.0.0.1 and a client certificate signed by it, and a
// second CA that signed nothing here.
class Certificates {
 public:
  explicit Certificates(const std::string& dir) : dir_(dir) {
    std::ofstream(dir + "/san.ext") << "subjectAltName=DNS:localhost,IP:127.0.0.1\n";
    ok_ = Run("req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -days 2 "
              "-keyout ca.key -out ca.pem -subj /CN=waymark-test-ca") &&
          Run("req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -days 2 "
              "-keyout other-ca.key -out other-ca.pem -subj /CN=other-ca") &&
          Issue("server", "localhost", true) && Issue("client", "robot-1", false);
  }
  bool ok() const { return ok_; }
  std::string Path(const std::string& name) const { return dir_ + "/" + name; }

 private:
  bool Run(const std::string& args) {
    const std::string command = "cd " + dir_ + " && openssl " + args + " >/dev/null 2>&1";
    return std::system(command.c_str()) == 0;
  }
  bool Issue(const std::string& name, const std::string& cn, bool san) {
    return Run("req -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -keyout " + name +
               ".key -out " + name + ".csr -subj /CN=" + cn) &&
           Run("x509 -req -in " + name + ".csr -CA ca.pem -CAkey ca.key -CAcreateserial -days 2 -out " +
               name + ".pem" + (san ? " -extfile san.ext" : ""));
  }
  std::string dir_;
  bool ok_ = false;
};

class TlsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::MakeTempDir("tls");
    certs_ = std::make_unique<Certificates>(dir_);
    ASSERT_TRUE(certs_->ok()) << "openssl failed to make test certificates in " << dir_;
    auto store = storage::OpenSqliteTokenStore(dir_ + "/waymark.db");
    ASSERT_TRUE(store.ok()) << store.status();
    auto created = (*store)->CreateToken("r1", "robot-1", storage::TokenRole::kRobot, {});
    ASSERT_TRUE(created.ok()) << created.status();
    token_ = created->secret;
  }

  absl::StatusOr<std::unique_ptr<testing::ServerProcess>> StartTls(bool mutual) {
    std::vector<std::string> args = {"--tls-cert", certs_->Path("server.pem"), "--tls-key",
                                     certs_->Path("server.key")};
    if (mutual) {
      args.push_back("--tls-client-ca");
      args.push_back(certs_->Path("ca.pem"));
    }
    return testing::ServerProcess::StartWithAuth(testing::ServerBinary(), dir_ + "/waymark.db",
                                                 args);
  }

  // ListDatabases over a channel with `tls` files (empty ca = plaintext).
  grpc::Status List(const std::string& address, const client::TlsFiles& tls, bool plaintext) {
    client::ChannelOptions options;
    options.bearer_token = token_;
    if (!plaintext) {
      auto credentials = client::MakeTlsCredentials(tls);
      if (!credentials.ok()) return grpc::Status(grpc::StatusCode::INTERNAL, "bad test files");
      options.credentials = *credentials;
    }
    v1::CrossingService::Stub stub(client::MakeChannel(address, options));
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    v1::ListDatabasesResponse response;
    return stub.ListDatabases(&context, {}, &response);
  }

  std::string dir_;
  std::unique_ptr<Certificates> certs_;
  std::string token_;
};

TEST_F(TlsTest, TrustedCaConnectsUntrustedCaAndPlaintextDoNot) {
  auto server = StartTls(false);
  ASSERT_TRUE(server.ok()) << server.status();
  const std::string address = (*server)->address();
  const grpc::Status trusted = List(address, {certs_->Path("ca.pem"), "", ""}, false);
  EXPECT_TRUE(trusted.ok()) << trusted.error_message();
  const grpc::Status untrusted = List(address, {certs_->Path("other-ca.pem"), "", ""}, false);
  EXPECT_EQ(untrusted.error_code(), grpc::StatusCode::UNAVAILABLE) << untrusted.error_message();
  const grpc::Status plaintext = List(address, {}, true);
  EXPECT_EQ(plaintext.error_code(), grpc::StatusCode::UNAVAILABLE) << plaintext.error_message();

  // The CLI the same way (what robots and the container health check run).
  const std::string at = "--server " + address + " --timeout 10 ";
  testing::CommandResult health =
      testing::RunBinary("waymark", at + "--tls-ca " + certs_->Path("ca.pem") + " health");
  EXPECT_EQ(health.code, 0) << health.output;
  testing::CommandResult listed = testing::RunBinary(
      "waymark", at + "--tls-ca " + certs_->Path("ca.pem") + " --token " + token_ + " db list");
  EXPECT_EQ(listed.code, 0) << listed.output;
  testing::CommandResult no_tls = testing::RunBinary("waymark", at + "health");
  EXPECT_EQ(no_tls.code, 1) << no_tls.output;
  testing::CommandResult missing_ca =
      testing::RunBinary("waymark", at + "--tls-ca " + dir_ + "/nope.pem health");
  EXPECT_EQ(missing_ca.code, 1);
  EXPECT_THAT(missing_ca.output, HasSubstr("nope.pem"));
}

TEST_F(TlsTest, MutualTlsNeedsAClientCertificateFromTheCa) {
  auto server = StartTls(true);
  ASSERT_TRUE(server.ok()) << server.status();
  const std::string address = (*server)->address();
  const grpc::Status without = List(address, {certs_->Path("ca.pem"), "", ""}, false);
  EXPECT_EQ(without.error_code(), grpc::StatusCode::UNAVAILABLE) << without.error_message();
  const grpc::Status with =
      List(address, {certs_->Path("ca.pem"), certs_->Path("client.pem"), certs_->Path("client.key")},
           false);
  EXPECT_TRUE(with.ok()) << with.error_message();
}

TEST_F(TlsTest, UnsafeListenSetupsAreRefusedWithAReason) {
  const std::string db = dir_ + "/refused.db";
  testing::CommandResult plain =
      testing::RunBinary("waymark-server", "--listen 0.0.0.0:0 --db " + db);
  EXPECT_EQ(plain.code, 2);
  EXPECT_THAT(plain.output, HasSubstr("--allow-plaintext"));
  testing::CommandResult dev =
      testing::RunBinary("waymark-server", "--listen 0.0.0.0:0 --insecure-dev --db " + db);
  EXPECT_EQ(dev.code, 2);
  EXPECT_THAT(dev.output, HasSubstr("loopback"));
  testing::CommandResult half = testing::RunBinary(
      "waymark-server", "--listen 0.0.0.0:0 --tls-cert " + certs_->Path("server.pem") + " --db " + db);
  EXPECT_EQ(half.code, 2);
  EXPECT_THAT(half.output, HasSubstr("--tls-key"));
  // Explicitly allowed plaintext off loopback starts (auth still on).
  auto allowed = testing::ServerProcess::StartWithAuth(testing::ServerBinary(), db,
                                                       {"--allow-plaintext"}, "0.0.0.0:0");
  EXPECT_TRUE(allowed.ok()) << allowed.status();
}

}  // namespace
}  // namespace waymark
