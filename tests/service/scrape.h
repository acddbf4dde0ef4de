#ifndef WAYMARK_TESTS_SERVICE_SCRAPE_H_
#define WAYMARK_TESTS_SERVICE_SCRAPE_H_

// What Prometheus does, for tests: GET the metrics page over a plain socket and read samples.

#include <optional>
#include <string>

#include "absl/status/statusor.h"

namespace waymark::testing {

// The body of http://127.0.0.1:`port``path`; an error unless the server answers 200.
absl::StatusOr<std::string> HttpGet(int port, const std::string& path = "/metrics");

// The value of the sample `series` in Prometheus text `page`, written exactly as the text format
// writes it (labels sorted by name): `waymark_rpc_requests_total{code="OK",method="/a.B/C"}`.
// nullopt when the page has no such sample.
std::optional<double> Sample(const std::string& page, const std::string& series);

}  // namespace waymark::testing

#endif  // WAYMARK_TESTS_SERVICE_SCRAPE_H_
