#ifndef WAYMARK_TESTS_SERVICE_REGISTRY_ON_FILE_H_
#define WAYMARK_TESTS_SERVICE_REGISTRY_ON_FILE_H_

// A crossing registry on a SQLite file or a PostgreSQL database (a libpq URI), loaded as
// waymark-server loads it: what the registry tests restart to check that memory and disk agree.

#include <memory>
#include <string>

#include "gtest/gtest.h"
#include "server/service/crossing/crossing_registry.h"
#include "storage/crossing_store.h"
#include "storage/open_stores.h"

namespace waymark::testing {

// nullptr (and a test failure) when the database cannot be opened or loaded.
inline std::unique_ptr<service::CrossingRegistry> LoadRegistry(const std::string& path) {
  auto store = storage::OpenCrossingStore(path);
  if (!store.ok()) {
    ADD_FAILURE() << store.status();
    return nullptr;
  }
  auto registry = service::CrossingRegistry::Load(std::move(*store));
  if (!registry.ok()) {
    ADD_FAILURE() << registry.status();
    return nullptr;
  }
  return *std::move(registry);
}

}  // namespace waymark::testing

#endif  // WAYMARK_TESTS_SERVICE_REGISTRY_ON_FILE_H_
