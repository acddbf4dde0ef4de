#ifndef WAYMARK_STORAGE_SHA256_H_
#define WAYMARK_STORAGE_SHA256_H_

// SHA-256 digests, the keys the stores look rows up by without keeping what was hashed (token
// secrets) or without comparing large blobs (the encoded image of a crossing view). OpenSSL's
// libcrypto (libssl-dev) does the hashing.

#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace waymark::storage {

inline constexpr int kSha256Bytes = 32;

// The 32-byte digest of `bytes`; INTERNAL if OpenSSL fails (it does not on a working build).
absl::StatusOr<std::string> Sha256(absl::string_view bytes);

// Lower-case hex of a digest (or of any bytes), for people and logs.
std::string HexString(absl::string_view bytes);

}  // namespace waymark::storage

#endif  // WAYMARK_STORAGE_SHA256_H_
