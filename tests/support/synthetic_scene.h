#ifndef WAYMARK_TESTS_SUPPORT_SYNTHETIC_SCENE_H_
#define WAYMARK_TESTS_SUPPORT_SYNTHETIC_SCENE_H_

// Generated test scenes: the simulated camera's panoramas (client/sim/sim_scene.h), which
// `waymark bench load` uses too, under the names the tests know them by.

#include "client/sim/sim_scene.h"

namespace waymark::testing {

using adapters::CropView;
using adapters::EncodeJpeg;
using adapters::EncodePng;
using adapters::MakePanorama;

}  // namespace waymark::testing

#endif  // WAYMARK_TESTS_SUPPORT_SYNTHETIC_SCENE_H_
