#ifndef WAYMARK_SERVER_SERVICE_AUTH_SERVER_SECURITY_H_
#define WAYMARK_SERVER_SERVICE_AUTH_SERVER_SECURITY_H_

// How the server protects its port (issue 6): TLS from PEM files, and the rule that plaintext is
// only served on loopback unless the operator says otherwise.

#include <grpcpp/security/server_credentials.h>

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "server/service/auth/folder.h"

namespace waymark::service {

struct SecurityOptions {
  std::string tls_cert;       // PEM certificate chain of the server; empty = plaintext
  std::string tls_key;        // PEM private key matching tls_cert
  std::string tls_client_ca;  // PEM CA(s); set = clients must present a certificate it signed
  bool allow_plaintext = false;  // plaintext on a non-loopback address (e.g. behind a TLS proxy)
  bool insecure_dev = false;     // auth off; loopback only
};

// True for 127.0.0.0/8, ::1, localhost and unix-domain sockets: addresses no other machine reaches.
bool IsLoopbackListen(const std::string& listen);

// The credentials for `listen`, or FAILED_PRECONDITION / NOT_FOUND explaining a refused setup:
// TLS half-configured, unreadable PEM files, --insecure-dev off loopback, plaintext off loopback
// without allow_plaintext.
absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> MakeServerCredentials(
    const std::string& listen, const SecurityOptions& options);

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_AUTH_SERVER_SECURITY_H_
