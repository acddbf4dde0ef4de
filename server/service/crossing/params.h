#ifndef WAYMARK_SERVER_SERVICE_CROSSING_PARAMS_H_
#define WAYMARK_SERVER_SERVICE_CROSSING_PARAMS_H_

// Translation between the API's parameter messages and the engine's Options structs, with the
// layering users expect: request value, else the database's value, else the engine default (the
// paper's parameter).

#include <string>

#include "absl/status/statusor.h"
#include "server/crossing/options.h"
#include "server/service/crossing/folder.h"
#include "waymark/v1/crossing.pb.h"

namespace waymark::service {

struct DatabaseOptions {
  crossing::FeatureOptions features;
  crossing::ClusterOptions clustering;
  crossing::RecognitionOptions recognition;  // the database's defaults for requests
};

// Fills every unset field with the engine default and validates. INVALID_ARGUMENT with the
// offending field named.
absl::StatusOr<v1::DatabaseParams> EffectiveDatabaseParams(const v1::DatabaseParams& requested);

// `params` must be effective (all fields set), as stored.
DatabaseOptions ToDatabaseOptions(const v1::DatabaseParams& params);

// The database's recognition defaults overridden by the request's set fields; validated.
absl::StatusOr<crossing::RecognitionOptions> ResolveRecognitionOptions(
    const crossing::RecognitionOptions& database_defaults, const v1::RecognitionParams& request);

v1::RecognitionMode ToProtoMode(crossing::RecognitionMode mode);

// Storage keeps params as JSON text so a human can read the database.
std::string ParamsToJson(const v1::DatabaseParams& params);
absl::StatusOr<v1::DatabaseParams> ParamsFromJson(const std::string& json);

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_CROSSING_PARAMS_H_
