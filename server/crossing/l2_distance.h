#ifndef WAYMARK_SERVER_CROSSING_L2_DISTANCE_H_
#define WAYMARK_SERVER_CROSSING_L2_DISTANCE_H_

#include <cstdint>

namespace waymark::crossing {

// Squared Euclidean distance of two 128-byte SIFT descriptors (exact, fits in int32: at most
// 128 * 255^2). The hot loop of every matcher here; compiled for AVX2 where the CPU has it.
int32_t SquaredL2(const uint8_t* a, const uint8_t* b);

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_L2_DISTANCE_H_
