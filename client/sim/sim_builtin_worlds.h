#ifndef WAYMARK_CLIENT_SIM_SIM_BUILTIN_WORLDS_H_
#define WAYMARK_CLIENT_SIM_SIM_BUILTIN_WORLDS_H_

// The texts of the built-in simulator worlds (sim_world.h format); LoadWorld parses them.

#include "absl/strings/string_view.h"

namespace waymark::adapters {

// The world text of a built-in world, or nullptr when `name` is not one.
const char* BuiltinWorldText(absl::string_view name);

}  // namespace waymark::adapters

#endif  // WAYMARK_CLIENT_SIM_SIM_BUILTIN_WORLDS_H_
